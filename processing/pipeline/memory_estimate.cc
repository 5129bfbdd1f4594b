// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/pipeline/memory_estimate.h"

#include <malloc.h>

#include <algorithm>
#include <functional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "processing/base/status_macros.h"
#include "processing/experiment/method.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/io/image.h"
#include "processing/pipeline/frame_selection.h"

namespace hdrstereo::pipeline {
namespace {

// The process itself: code, libraries, OpenCV's and the allocator's pools,
// thread stacks (a whole run at 240 x 180 peaks at about 100 MiB).
constexpr double kBaseBytes = 200.0 * (1 << 20);

// Working sets in bytes per pixel beyond the images a step holds,
// measured on lab-lamp at 6000 x 4000 (matched at 1600 x 1067, 2 threads;
// docs/results.md) with some margin.
constexpr double kHdrMerge = 36;           // float accumulators, 3 channels
constexpr double kRadiancePair = 24;       // both views, float, 3 channels
constexpr double kMapsWritten = 8;         // a float map resized, written
constexpr double kTruthFiles = 20;         // disparities and masks
constexpr double kToneMapFirst = 124;      // the radiance pair + WLS's solver
constexpr double kToneMapEachMore = 25;    // each further operator at once
constexpr double kDecodedView = 16;        // a view's codes, bits, masks
constexpr double kFrameLoading = 3;        // a colour frame made grey
constexpr double kMatchingPairs = 72;      // nine pairs at the matching size
constexpr double kMatchingEach = 150;      // a matching's cost slices
constexpr double kFusionWorkingSet = 600;  // candidates, weights, graph cuts
constexpr double kDisparityMaps = 50;      // a dozen float maps
constexpr double kReportMaps = 70;         // maps, truths, figures

struct Counts {
  double image = 0;      // stereo pixels
  double stack = 0;      // bytes of one view's decoded stack
  double frame = 0;      // bytes of one decoded stereo frame
  double sl_frames = 0;  // bytes of one view's grey structured light
  double sl_pixels = 0;
  double matching = 0;  // pixels at the matching size
  int threads = 1;
};

double StepPeak(const std::string& step, const Counts& c) {
  const auto units = [&](int n) { return std::min(c.threads, n); };
  if (step == "decode") return 2 * c.frame;
  if (step == "rectify") return 2 * c.stack + c.frame;
  if (step == "response") return c.stack;
  if (step == "hdr") return c.stack + kHdrMerge * c.image;
  if (step == "tonemap") {
    const int operators =
        static_cast<int>(experiment::ToneMappedMethods().size());
    return c.image *
           (kToneMapFirst + kToneMapEachMore * (units(operators) - 1));
  }
  // One view at a time (ground_truth_step.cc) beside the other's codes.
  if (step == "sl_groundtruth") {
    return c.sl_frames + (2 * kDecodedView + kFrameLoading) * c.sl_pixels;
  }
  if (step == "stereo") {
    // Both stacks, the radiance pair and the maps written back.
    return 2 * c.stack + (kRadiancePair + kMapsWritten) * c.image +
           c.matching *
               (kMatchingPairs +
                kMatchingEach * units(static_cast<int>(
                                    experiment::MatchedMethods().size())));
  }
  if (step == "fusion") {
    return c.stack + 3 * kMapsWritten * c.image +
           kFusionWorkingSet * c.matching;
  }
  if (step == "evaluate") return kDisparityMaps * c.image;
  if (step == "export") return 2 * c.stack + kTruthFiles * c.image;
  if (step == "report") return 2 * c.stack + kReportMaps * c.image;
  return 0;
}

// Whether `a` needs `b`, directly or through other steps.
bool Needs(const std::string& a, const std::string& b) {
  for (const std::string& d : StepDependencies(a)) {
    if (d == b || Needs(d, b)) return true;
  }
  return false;
}

}  // namespace

void ReturnFreedImagesToTheSystem() { ::mallopt(M_MMAP_THRESHOLD, 1 << 20); }

std::string FormatBytes(int64_t bytes) {
  const double gib = static_cast<double>(bytes) / (1 << 30);
  if (gib >= 1) return absl::StrFormat("%.1f GiB", gib);
  return absl::StrFormat("%.0f MiB", static_cast<double>(bytes) / (1 << 20));
}

std::string MemoryEstimate::Describe(const RunShape& shape) const {
  std::string what =
      absl::StrCat(shape.image.width, " x ", shape.image.height, " frames, ",
                   shape.exposures, " exposures a view");
  if (shape.sl_frames > 0) {
    absl::StrAppend(&what, ", ", shape.sl_frames,
                    " structured-light frames a view");
  }
  return absl::StrCat("about ", FormatBytes(peak_bytes), " at the peak (",
                      steps, ": ", what, ")");
}

absl::StatusOr<MemoryEstimate> EstimateMemory(const RunShape& shape,
                                              const RunOptions& options) {
  if (shape.image.empty() || shape.exposures <= 0) {
    return absl::InvalidArgumentError(
        "memory estimate: the session has no stereo frames");
  }
  ASSIGN_OR_RETURN(const std::vector<std::string> steps,
                   ResolveSteps(options.steps));
  Counts c;
  c.image = static_cast<double>(shape.image.area());
  c.frame = c.image * shape.bytes_per_pixel;
  c.stack = c.frame * shape.exposures;
  c.sl_pixels = static_cast<double>(shape.sl_image.area());
  c.sl_frames = c.sl_pixels * shape.sl_bytes_per_sample * shape.sl_frames;
  c.matching = static_cast<double>(
      experiment::MatchingSize(shape.image,
                               options.step_options.experiment.matching_width)
          .area());
  c.threads = std::max(1, options.threads);

  // Every set of up to `threads` steps of which none needs another may run
  // at once; the largest sum is the peak.
  MemoryEstimate best;
  double best_bytes = -1;
  std::vector<std::string> chosen;
  std::function<void(size_t, double)> visit = [&](size_t from, double sum) {
    if (!chosen.empty() && sum > best_bytes) {
      best_bytes = sum;
      best.steps = absl::StrJoin(chosen, " + ");
    }
    if (static_cast<int>(chosen.size()) == c.threads) return;
    for (size_t i = from; i < steps.size(); ++i) {
      const bool independent =
          std::none_of(chosen.begin(), chosen.end(), [&](const std::string& s) {
            return Needs(s, steps[i]) || Needs(steps[i], s);
          });
      if (!independent) continue;
      chosen.push_back(steps[i]);
      visit(i + 1, sum + StepPeak(steps[i], c));
      chosen.pop_back();
    }
  };
  visit(0, 0);
  best.peak_bytes = static_cast<int64_t>(kBaseBytes + best_bytes);
  return best;
}

absl::StatusOr<RunShape> ShapeOfSession(const SessionInput& input) {
  ASSIGN_OR_RETURN(const FrameSelection frames, SelectFrames(input));
  if (frames.stereo[0].empty()) {
    return absl::FailedPreconditionError(
        "memory estimate: the session has no stereo frames");
  }
  RunShape shape;
  ASSIGN_OR_RETURN(
      const io::DecodedImage first,
      io::DecodeImageFile(input.session_dir / frames.stereo[0].front().path));
  shape.image = first.pixels.size();
  shape.bytes_per_pixel = static_cast<int>(first.pixels.elemSize());
  shape.exposures = static_cast<int>(frames.stereo[0].size());
  if (!frames.structured_light.empty()) {
    ASSIGN_OR_RETURN(const io::DecodedImage sl,
                     io::DecodeImageFile(input.session_dir /
                                         frames.structured_light.front().path));
    shape.sl_image = sl.pixels.size();
    shape.sl_bytes_per_sample = static_cast<int>(sl.pixels.elemSize1());
    int left = 0;
    for (const FrameInput& f : frames.structured_light) {
      if (f.view_index == 0) ++left;
    }
    shape.sl_frames = left;
  }
  return shape;
}

}  // namespace hdrstereo::pipeline
