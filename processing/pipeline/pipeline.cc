// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/pipeline/pipeline.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/calib/stereo_calibration.h"
#include "processing/eval/disparity_eval.h"
#include "processing/fusion/fusion.h"
#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "processing/hdr/stack.h"
#include "processing/io/atomic_file.h"
#include "processing/io/capture_layout.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/io/middlebury.h"
#include "processing/io/sha256.h"
#include "processing/pipeline/session_files.h"
#include "processing/report/html_report.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/structured_light/capture_io.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/gray_code.h"
#include "processing/structured_light/ground_truth.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
using io::ExposureTag;
using nlohmann::json;

namespace {

// Part of every input hash: bump when a step's outputs change meaning.
constexpr char kVersion[] = "hdrstereo-pipeline-1";
// Disparity range when there is no ground truth to take it from.
constexpr int kDefaultMaxDisparity = 64;
// Added to the largest ground-truth disparity (as the thesis table does).
constexpr int kDisparityMargin = 2;
constexpr char kSlDir[] = "ground_truth/structured_light";
constexpr char kSimulation[] = "simulation";
constexpr char kStructuredLight[] = "structured_light";

struct StepDef {
  std::string name;
  std::vector<std::string> deps;
};

const std::vector<StepDef>& Defs() {
  static const std::vector<StepDef>* defs = new std::vector<StepDef>{
      {"decode", {}},
      {"rectify", {"decode"}},
      {"response", {"rectify"}},
      {"hdr", {"rectify", "response"}},
      {"tonemap", {"hdr"}},
      {"sl_groundtruth", {}},
      {"stereo", {"rectify", "hdr", "tonemap", "sl_groundtruth"}},
      {"fusion", {"rectify", "stereo", "sl_groundtruth"}},
      {"evaluate", {"stereo", "fusion", "sl_groundtruth"}},
      {"export", {"rectify", "sl_groundtruth"}},
      {"report",
       {"rectify", "tonemap", "stereo", "fusion", "sl_groundtruth",
        "evaluate"}},
  };
  return *defs;
}

// The pipeline's own folders (decoded/, exposures/) name the views as the
// capture layout does.
std::string ViewName(int v) { return io::ViewName(v); }

std::vector<std::string> OperatorNames() {
  std::vector<std::string> out;
  for (tonemap::Operator op : tonemap::AllOperators()) {
    out.push_back(tonemap::OperatorName(op));
  }
  return out;
}

// Matched methods (stereo step), then the fused ones (fusion step).
std::vector<std::string> StereoMethods() {
  std::vector<std::string> out = {"ldr"};
  for (const std::string& op : OperatorNames()) out.push_back(op);
  out.push_back("hdr");
  return out;
}
const std::vector<std::string>& FusedMethods() {
  static const std::vector<std::string>* m =
      new std::vector<std::string>{"mean", "median", "fused"};
  return *m;
}

cv::Mat To8Bit(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  cv::Mat out;
  if (image.depth() == CV_16U) {
    image.convertTo(out, CV_8U, 1.0 / 257.0);
  } else {
    image.convertTo(out, CV_8U, 255.0);
  }
  return out;
}

double MaxFinite(const cv::Mat& disparity) {
  double hi = 0;
  cv::Mat finite = disparity == disparity;  // not NaN
  finite &= disparity < std::numeric_limits<float>::infinity();
  if (cv::countNonZero(finite) == 0) return 0;
  cv::minMaxLoc(disparity, nullptr, &hi, nullptr, nullptr, finite);
  return hi;
}

// What one step runs with (built once, hashed and used) and what it wrote
// (relative paths; sha256 filled in afterwards).
struct StepIo {
  std::string step;
  std::string params;  // canonical JSON of what the step runs with
  std::vector<Artifact> outputs;
  // stereo and fusion: their options with the disparity range set.
  stereo::StereoOptions ldr_stereo;
  stereo::StereoOptions hdr_stereo;
  fusion::FusionParams fusion;
};

struct Selection {
  std::vector<FrameInput> stereo[2];  // longest exposure first
  std::vector<FrameInput> calibration[2];
  std::vector<FrameInput> sl;
  int64_t sl_capture = -1;
  std::string sl_view_folder[2];  // "left"/"view0", ...
};

class Runner {
 public:
  Runner(const SessionInput& input, const RunOptions& options, RunStore& store,
         RunObserver& observer)
      : in_(input),
        dir_(input.session_dir),
        options_(options),
        store_(store),
        observer_(observer) {}

  absl::StatusOr<RunSummary> Run();

 private:
  using StepFn = absl::Status (Runner::*)(StepIo&);

  absl::Status Preflight(const std::vector<std::string>& steps);
  absl::Status ExecuteStep(const std::string& step);
  absl::StatusOr<std::vector<std::pair<std::string, std::string>>> InputsOf(
      const std::string& step);
  // Builds what `step` runs with into `io` (io.params and, for stereo and
  // fusion, their options).
  absl::Status Configure(StepIo& io);
  bool Verified(const std::vector<Artifact>& artifacts);

  absl::Status Decode(StepIo& io);
  absl::Status RectifyStep(StepIo& io);
  absl::Status Response(StepIo& io);
  absl::Status Hdr(StepIo& io);
  absl::Status Tonemap(StepIo& io);
  absl::Status SlGroundTruth(StepIo& io);
  absl::Status Stereo(StepIo& io);
  absl::Status Fusion(StepIo& io);
  absl::Status Evaluate(StepIo& io);
  absl::Status Export(StepIo& io);
  absl::Status Report(StepIo& io);

  // Serialised access to the caller's store and observer.
  absl::Status Checkpoint() {
    std::lock_guard<std::mutex> l(caller_mu_);
    return observer_.Checkpoint();
  }
  void Progress(int64_t done, int64_t total, const std::string& what) {
    std::lock_guard<std::mutex> l(caller_mu_);
    observer_.Progress(done, total, what);
  }
  void Info(const std::string& m) {
    std::lock_guard<std::mutex> l(caller_mu_);
    observer_.Info(m);
  }
  void Warn(const std::string& m) {
    std::lock_guard<std::mutex> l(caller_mu_);
    observer_.Warn(m);
  }

  // Runs fn(0..n-1) on up to options_.threads threads, checking the
  // observer before each unit; the first error stops the rest.
  absl::Status ParallelFor(int n, const std::string& step,
                           const std::vector<std::string>& names,
                           const std::function<absl::Status(int)>& fn);

  bool HasOutput(const std::string& step, const std::string& path) {
    std::lock_guard<std::mutex> l(outputs_mu_);
    for (const Artifact& a : outputs_[step]) {
      if (a.path == path) return true;
    }
    return false;
  }
  bool HasSlTruth() {
    return HasOutput("sl_groundtruth",
                     absl::StrCat(kSlDir, "/", io::kDisparity0File));
  }

  absl::Status Write(StepIo& io, const std::string& kind,
                     const std::string& rel, const cv::Mat& image,
                     const std::string& params = "");
  // Creates the folder, writes `rel` with `write` (atomically) and adds it
  // to the step's outputs.
  absl::Status WriteOutput(
      StepIo& io, const std::string& kind, const std::string& rel,
      const std::string& params,
      const std::function<absl::Status(const fs::path&)>& write);
  absl::Status WriteText(StepIo& io, const std::string& kind,
                         const std::string& rel, const std::string& text);
  absl::Status CopyFile(StepIo& io, const std::string& kind,
                        const std::string& from_rel, const std::string& rel);
  absl::StatusOr<cv::Mat> Read(const std::string& rel) const;
  absl::StatusOr<cv::Mat> ReadPfm(const std::string& rel) const {
    return io::ReadPfm(dir_ / rel);
  }
  absl::StatusOr<hdr::ExposureStack> Stack(int view) const {
    return hdr::LoadStack(dir_ / "exposures" / ViewName(view));
  }
  size_t LdrIndex() const { return sel_.stereo[0].size() / 2; }
  absl::StatusOr<int> MaxDisparity(int width);
  // Ground truths available to evaluate/export, best first.
  struct Truth {
    std::string name;
    cv::Mat disparity;    // CV_32FC1, +inf unknown
    cv::Mat nonoccluded;  // CV_8UC1 255 = scored
    cv::Mat mask0nocc;    // io::kMaskNonOccluded / kMaskOccluded / ...
  };
  absl::StatusOr<std::vector<Truth>> Truths();

  const SessionInput& in_;
  const fs::path dir_;
  const RunOptions options_;
  RunStore& store_;
  RunObserver& observer_;
  std::mutex caller_mu_;
  Selection sel_;

  std::mutex outputs_mu_;
  std::map<std::string, std::vector<Artifact>> outputs_;
  std::vector<std::string> computed_, reused_;
  std::vector<Metric> metrics_;
  bool have_metrics_ = false;
};

absl::Status Runner::ParallelFor(int n, const std::string& step,
                                 const std::vector<std::string>& names,
                                 const std::function<absl::Status(int)>& fn) {
  std::atomic<int> next{0};
  std::atomic<int> done{0};
  std::mutex mu;
  absl::Status first;
  auto work = [&] {
    for (;;) {
      {
        std::lock_guard<std::mutex> l(mu);
        if (!first.ok()) return;
      }
      const int i = next.fetch_add(1);
      if (i >= n) return;
      absl::Status s = Checkpoint();
      if (s.ok()) {
        try {
          s = fn(i);
        } catch (const cv::Exception& e) {
          s = absl::InternalError(absl::StrCat(step, ": OpenCV: ", e.what()));
        }
      }
      if (!s.ok()) {
        std::lock_guard<std::mutex> l(mu);
        if (first.ok()) first = s;
        return;
      }
      Progress(done.fetch_add(1) + 1, n,
               absl::StrCat(step, ": ", names[static_cast<size_t>(i)]));
    }
  };
  const int threads = std::clamp(options_.threads, 1, std::max(n, 1));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  return first;
}

absl::Status Runner::Write(StepIo& io, const std::string& kind,
                           const std::string& rel, const cv::Mat& image,
                           const std::string& params) {
  return WriteOutput(io, kind, rel, params, [&](const fs::path& path) {
    return io::WriteImage(path, image);
  });
}

absl::Status Runner::WriteText(StepIo& io, const std::string& kind,
                               const std::string& rel,
                               const std::string& text) {
  return WriteOutput(io, kind, rel, "", [&](const fs::path& path) {
    return io::WriteFileAtomically(path, text);
  });
}

absl::Status Runner::WriteOutput(
    StepIo& io, const std::string& kind, const std::string& rel,
    const std::string& params,
    const std::function<absl::Status(const fs::path&)>& write) {
  const fs::path path = dir_ / rel;
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat(path.parent_path().string(), ": ", ec.message()));
  }
  if (absl::Status s = write(path); !s.ok()) return s;
  Artifact a;
  a.step = io.step;
  a.kind = kind;
  a.path = rel;
  a.params_json = params.empty() ? io.params : params;
  io.outputs.push_back(std::move(a));
  return absl::OkStatus();
}

absl::Status Runner::CopyFile(StepIo& io, const std::string& kind,
                              const std::string& from_rel,
                              const std::string& rel) {
  absl::StatusOr<std::string> bytes = io::ReadFileBytes(dir_ / from_rel);
  if (!bytes.ok()) return bytes.status();
  return WriteText(io, kind, rel, *bytes);
}

absl::StatusOr<cv::Mat> Runner::Read(const std::string& rel) const {
  absl::StatusOr<io::DecodedImage> image = io::DecodeImageFile(dir_ / rel);
  if (!image.ok()) return image.status();
  return image->pixels;
}

absl::StatusOr<int> Runner::MaxDisparity(int width) {
  double hi = -1;
  if (HasSlTruth()) {
    absl::StatusOr<cv::Mat> d =
        ReadPfm(absl::StrCat(kSlDir, "/", io::kDisparity0File));
    if (!d.ok()) return d.status();
    hi = std::max(hi, MaxFinite(*d));
  }
  if (!in_.sim_truth_disparity.empty()) {
    absl::StatusOr<cv::Mat> d = ReadPfm(in_.sim_truth_disparity);
    if (!d.ok()) return d.status();
    hi = std::max(hi, MaxFinite(*d));
  }
  int max_disp = hi > 0 ? static_cast<int>(std::ceil(hi)) + kDisparityMargin
                        : kDefaultMaxDisparity;
  // The matcher needs every disparity to stay inside the image.
  return std::clamp(max_disp, 1, std::max(1, width - 2));
}

absl::StatusOr<std::vector<Runner::Truth>> Runner::Truths() {
  std::vector<Truth> out;
  if (HasSlTruth()) {
    Truth t;
    t.name = kStructuredLight;
    absl::StatusOr<cv::Mat> d =
        ReadPfm(absl::StrCat(kSlDir, "/", io::kDisparity0File));
    if (!d.ok()) return d.status();
    absl::StatusOr<cv::Mat> m = Read(absl::StrCat(kSlDir, "/", io::kMask0File));
    if (!m.ok()) return m.status();
    t.disparity = *d;
    t.mask0nocc = *m;
    t.nonoccluded = *m == io::kMaskNonOccluded;
    out.push_back(std::move(t));
  }
  if (!in_.sim_truth_disparity.empty()) {
    Truth t;
    t.name = kSimulation;
    absl::StatusOr<cv::Mat> d = ReadPfm(in_.sim_truth_disparity);
    if (!d.ok()) return d.status();
    t.disparity = *d;
    cv::Mat nonoccluded;
    if (!in_.sim_truth_nonoccluded.empty()) {
      absl::StatusOr<cv::Mat> m = Read(in_.sim_truth_nonoccluded);
      if (!m.ok()) return m.status();
      nonoccluded = *m;
    }
    t.mask0nocc = io::MaskFromTruth(t.disparity, nonoccluded);
    t.nonoccluded = t.mask0nocc == io::kMaskNonOccluded;
    out.push_back(std::move(t));
  }
  return out;
}

// ---------------------------------------------------------------- steps

absl::Status Runner::Decode(StepIo& io) {
  for (int v = 0; v < 2; ++v) {
    std::string list;
    for (const FrameInput& f : sel_.stereo[v]) {
      absl::StatusOr<io::DecodedImage> image =
          io::DecodeImageFile(dir_ / f.path);
      if (!image.ok()) return image.status();
      const bool is_float = image->pixels.depth() == CV_32F;
      const std::string name = absl::StrCat("exp_", ExposureTag(f.exposure_s),
                                            is_float ? ".pfm" : ".png");
      if (absl::Status s = Write(
              io, "decoded", absl::StrCat("decoded/", ViewName(v), "/", name),
              image->pixels);
          !s.ok()) {
        return s;
      }
      absl::StrAppend(&list, name, " ", absl::StrFormat("%.17g", f.exposure_s),
                      "\n");
    }
    if (absl::Status s = WriteText(
            io, "decoded",
            absl::StrCat("decoded/", ViewName(v), "/exposures.txt"), list);
        !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

absl::Status Runner::RectifyStep(StepIo& io) {
  hdr::ExposureStack stacks[2];
  for (int v = 0; v < 2; ++v) {
    absl::StatusOr<hdr::ExposureStack> s =
        hdr::LoadStack(dir_ / "decoded" / ViewName(v));
    if (!s.ok()) return s.status();
    stacks[v] = std::move(*s);
  }
  std::optional<calib::RectificationMaps> maps;
  std::string note = "identity: no calibration capture in the session\n";
  if (!sel_.calibration[0].empty()) {
    std::vector<cv::Mat> images[2];
    std::vector<std::string> names[2];
    for (int v = 0; v < 2; ++v) {
      for (const FrameInput& f : sel_.calibration[v]) {
        absl::StatusOr<cv::Mat> image = Read(f.path);
        if (!image.ok()) return image.status();
        images[v].push_back(To8Bit(*image));
        names[v].push_back(f.path);
      }
    }
    absl::StatusOr<calib::StereoCalibration> c =
        calib::CalibrateStereoFromImages(images[0], images[1], names[0],
                                         names[1]);
    if (!c.ok()) return c.status();
    absl::StatusOr<calib::RectificationMaps> m =
        calib::ComputeRectificationMaps(*c);
    if (!m.ok()) return m.status();
    maps = std::move(*m);
    std::error_code ec;
    fs::create_directories(dir_ / "exposures", ec);
    const std::string rel = "exposures/rectification.yml";
    if (absl::Status s = calib::SaveCalibration(dir_ / rel, *c); !s.ok()) {
      return s;
    }
    io.outputs.push_back({io.step, "rectification", rel, io.params, "", 0});
    note = absl::StrFormat("calibrated: %d board pairs, rms %.3f px\n",
                           static_cast<int>(images[0].size()), c->rms_stereo);
  }
  for (int v = 0; v < 2; ++v) {
    std::string list;
    for (size_t i = 0; i < stacks[v].images.size(); ++i) {
      cv::Mat image = stacks[v].images[i];
      if (maps) {
        absl::StatusOr<cv::Mat> r = calib::Rectify(
            image, *maps, v == 0 ? calib::View::kLeft : calib::View::kRight);
        if (!r.ok()) return r.status();
        image = *r;
      }
      const std::string name = fs::path(stacks[v].names[i]).filename().string();
      if (absl::Status s =
              Write(io, "exposure",
                    absl::StrCat("exposures/", ViewName(v), "/", name), image);
          !s.ok()) {
        return s;
      }
      absl::StrAppend(&list, name, " ",
                      absl::StrFormat("%.17g", stacks[v].exposure_s[i]), "\n");
    }
    if (absl::Status s = WriteText(
            io, "exposure",
            absl::StrCat("exposures/", ViewName(v), "/exposures.txt"), list);
        !s.ok()) {
      return s;
    }
  }
  return WriteText(io, "rectification", "exposures/rectification.txt", note);
}

absl::Status Runner::Response(StepIo& io) {
  absl::StatusOr<hdr::ExposureStack> left = Stack(0);
  if (!left.ok()) return left.status();
  absl::StatusOr<hdr::CameraResponse> r =
      left->images[0].depth() == CV_8U
          ? hdr::RecoverResponse(*left, options_.step_options.response)
          : hdr::LinearResponse(left->camera);
  if (!r.ok()) return r.status();
  std::error_code ec;
  fs::create_directories(dir_ / "hdr", ec);
  const std::string rel = "hdr/response.yml";
  if (absl::Status s = hdr::SaveResponse(dir_ / rel, *r); !s.ok()) return s;
  io.outputs.push_back({io.step, "response", rel, io.params, "", 0});
  return absl::OkStatus();
}

absl::Status Runner::Hdr(StepIo& io) {
  absl::StatusOr<hdr::CameraResponse> r =
      hdr::LoadResponse(dir_ / "hdr/response.yml");
  if (!r.ok()) return r.status();
  for (int v = 0; v < 2; ++v) {
    absl::StatusOr<hdr::ExposureStack> stack = Stack(v);
    if (!stack.ok()) return stack.status();
    absl::StatusOr<hdr::MergeResult> m =
        hdr::MergeStack(*stack, *r, options_.step_options.merge);
    if (!m.ok()) return m.status();
    cv::Mat radiance = m->radiance;
    if (radiance.channels() == 1)
      cv::cvtColor(radiance, radiance, cv::COLOR_GRAY2BGR);
    if (absl::Status s =
            Write(io, "hdr", absl::StrCat("hdr/im", v, ".pfm"), radiance);
        !s.ok()) {
      return s;
    }
    Progress(v + 1, 2, absl::StrCat("hdr: ", ViewName(v)));
  }
  return absl::OkStatus();
}

absl::Status Runner::Tonemap(StepIo& io) {
  absl::StatusOr<cv::Mat> l = ReadPfm("hdr/im0.pfm");
  if (!l.ok()) return l.status();
  absl::StatusOr<cv::Mat> r = ReadPfm("hdr/im1.pfm");
  if (!r.ok()) return r.status();
  const std::vector<tonemap::Operator> ops = tonemap::AllOperators();
  const std::vector<std::string> names = OperatorNames();
  std::vector<StepIo> parts(ops.size(),
                            StepIo{io.step, io.params, {}, {}, {}, {}});
  absl::Status s = ParallelFor(
      static_cast<int>(ops.size()), io.step, names, [&](int i) -> absl::Status {
        const size_t k = static_cast<size_t>(i);
        absl::StatusOr<std::pair<cv::Mat, cv::Mat>> pair =
            tonemap::ToneMapPair(*l, *r, ops[k], options_.step_options.tonemap);
        if (!pair.ok()) return pair.status();
        const std::string base = absl::StrCat("tonemapped/", names[k], "/");
        if (absl::Status w = Write(parts[k], "tonemapped",
                                   absl::StrCat(base, "im0.png"), pair->first);
            !w.ok()) {
          return w;
        }
        return Write(parts[k], "tonemapped", absl::StrCat(base, "im1.png"),
                     pair->second);
      });
  if (!s.ok()) return s;
  for (StepIo& p : parts) {
    for (Artifact& a : p.outputs) io.outputs.push_back(std::move(a));
  }
  return absl::OkStatus();
}

absl::Status Runner::SlGroundTruth(StepIo& io) {
  if (sel_.sl.empty()) {
    Warn(
        "sl_groundtruth: the session has no structured-light capture: no "
        "structured-light ground truth");
    return absl::OkStatus();
  }
  const fs::path capture = dir_ / io::CaptureDir(sel_.sl_capture);
  std::optional<cv::Size> psize;
  if (in_.projector_size) {
    psize = cv::Size(in_.projector_size->first, in_.projector_size->second);
  }
  structured_light::DecodedView decoded[2];
  std::vector<std::string> names = {"decode left", "decode right",
                                    "ground truth"};
  absl::Status s = ParallelFor(2, io.step, names, [&](int v) -> absl::Status {
    absl::StatusOr<structured_light::ViewFrames> frames =
        structured_light::LoadCaptureView(capture, sel_.sl_view_folder[v],
                                          psize);
    if (!frames.ok()) {
      return absl::FailedPreconditionError(frames.status().message());
    }
    absl::StatusOr<structured_light::DecodedView> d =
        structured_light::Decode(*frames, options_.step_options.sl_decode);
    if (!d.ok()) return d.status();
    decoded[v] = std::move(*d);
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  for (int v = 0; v < 2; ++v) {
    for (const std::string& w : decoded[v].warnings) {
      Warn(absl::StrCat("sl_groundtruth: ", ViewName(v), ": ", w));
    }
  }
  absl::StatusOr<structured_light::GroundTruth> gt =
      structured_light::ComputeGroundTruth(
          decoded[0], decoded[1], options_.step_options.sl_ground_truth);
  if (!gt.ok()) return gt.status();
  for (const std::string& w : gt->warnings) {
    Warn(absl::StrCat("sl_groundtruth: ", w));
  }
  if (absl::Status w = structured_light::WriteMiddlebury(*gt, dir_ / kSlDir);
      !w.ok()) {
    return w;
  }
  for (const char* name : {io::kDisparity0File, io::kDisparity1File,
                           io::kMask0File, structured_light::kStatsFile}) {
    io.outputs.push_back({io.step, "ground_truth",
                          absl::StrCat(kSlDir, "/", name), io.params, "", 0});
  }
  Progress(3, 3, "sl_groundtruth: ground truth");
  return absl::OkStatus();
}

absl::Status Runner::Stereo(StepIo& io) {
  absl::StatusOr<hdr::ExposureStack> stacks[2] = {Stack(0), Stack(1)};
  for (const auto& s : stacks) {
    if (!s.ok()) return s.status();
  }
  Info(absl::StrCat("stereo: disparities 0..", io.ldr_stereo.max_disparity));
  const std::vector<std::string> methods = StereoMethods();
  std::vector<StepIo> parts(methods.size(),
                            StepIo{io.step, io.params, {}, {}, {}, {}});
  absl::Status s = ParallelFor(
      static_cast<int>(methods.size()), io.step, methods,
      [&](int i) -> absl::Status {
        const size_t k = static_cast<size_t>(i);
        const std::string& m = methods[k];
        cv::Mat left, right;
        const stereo::StereoOptions& o =
            m == "hdr" ? io.hdr_stereo : io.ldr_stereo;
        if (m == "ldr") {
          left = stacks[0]->images[LdrIndex()];
          right = stacks[1]->images[LdrIndex()];
        } else if (m == "hdr") {
          absl::StatusOr<cv::Mat> l = ReadPfm("hdr/im0.pfm");
          if (!l.ok()) return l.status();
          absl::StatusOr<cv::Mat> r = ReadPfm("hdr/im1.pfm");
          if (!r.ok()) return r.status();
          left = *l;
          right = *r;
        } else {
          absl::StatusOr<cv::Mat> l =
              Read(absl::StrCat("tonemapped/", m, "/im0.png"));
          if (!l.ok()) return l.status();
          absl::StatusOr<cv::Mat> r =
              Read(absl::StrCat("tonemapped/", m, "/im1.png"));
          if (!r.ok()) return r.status();
          left = *l;
          right = *r;
        }
        absl::StatusOr<stereo::StereoResult> d =
            stereo::ComputeDisparity(left, right, o);
        if (!d.ok()) {
          return absl::Status(
              d.status().code(),
              absl::StrCat("stereo ", m, ": ", d.status().message()));
        }
        return Write(parts[k], "disparity",
                     absl::StrCat("disparity/", m, ".pfm"), d->disparity);
      });
  if (!s.ok()) return s;
  for (StepIo& p : parts) {
    for (Artifact& a : p.outputs) io.outputs.push_back(std::move(a));
  }
  return absl::OkStatus();
}

absl::Status Runner::Fusion(StepIo& io) {
  absl::StatusOr<hdr::ExposureStack> left = Stack(0);
  if (!left.ok()) return left.status();
  const int max_disp = io.fusion.max_disp;
  std::vector<cv::Mat> candidates;
  for (const std::string& op : OperatorNames()) {
    absl::StatusOr<cv::Mat> d = ReadPfm(absl::StrCat("disparity/", op, ".pfm"));
    if (!d.ok()) return d.status();
    candidates.push_back(*d);
  }
  // The guide: the LDR middle exposure's left view (Appendix A: left.jpg).
  const cv::Mat guide = To8Bit(left->images[LdrIndex()]);
  const std::vector<std::string>& methods = FusedMethods();
  std::vector<StepIo> parts(methods.size(),
                            StepIo{io.step, io.params, {}, {}, {}, {}});
  absl::Status s = ParallelFor(
      static_cast<int>(methods.size()), io.step, methods,
      [&](int i) -> absl::Status {
        const size_t k = static_cast<size_t>(i);
        absl::StatusOr<cv::Mat> d;
        if (methods[k] == "mean") {
          d = fusion::FuseMean(candidates, max_disp);
        } else if (methods[k] == "median") {
          d = fusion::FuseMedian(candidates, max_disp);
        } else {
          absl::StatusOr<fusion::FusionResult> r =
              fusion::FuseAlphaExpansion(candidates, guide, io.fusion);
          if (!r.ok()) return r.status();
          d = r->disparity;
        }
        if (!d.ok()) return d.status();
        return Write(parts[k], "disparity",
                     absl::StrCat("disparity/", methods[k], ".pfm"), *d);
      });
  if (!s.ok()) return s;
  for (StepIo& p : parts) {
    for (Artifact& a : p.outputs) io.outputs.push_back(std::move(a));
  }
  return absl::OkStatus();
}

absl::Status Runner::Evaluate(StepIo& io) {
  absl::StatusOr<std::vector<Truth>> truths = Truths();
  if (!truths.ok()) return truths.status();
  std::vector<Metric> rows;
  if (truths->empty()) {
    Warn(
        "evaluate: no ground truth (no structured-light capture, no "
        "simulator truth): no metrics");
  }
  std::vector<std::string> methods = StereoMethods();
  for (const std::string& m : FusedMethods()) methods.push_back(m);
  for (const Truth& t : *truths) {
    for (const std::string& m : methods) {
      absl::StatusOr<cv::Mat> d =
          ReadPfm(absl::StrCat("disparity/", m, ".pfm"));
      if (!d.ok()) return d.status();
      absl::StatusOr<eval::DisparityEvaluation> e =
          eval::EvaluateDisparity(*d, t.disparity, t.nonoccluded, cv::Mat(),
                                  options_.step_options.evaluation);
      if (!e.ok()) {
        return absl::Status(e.status().code(),
                            absl::StrCat("evaluate ", m, " against ", t.name,
                                         ": ", e.status().message()));
      }
      const eval::RegionMetrics& r = e->nonoccluded;
      Metric row;
      row.method = m;
      row.ground_truth = t.name;
      row.rmse = r.rmse;
      row.mae = r.mae;
      row.bad_0_5 = r.bad_percent.at(0);
      row.bad_1 = r.bad_percent.at(1);
      row.bad_2 = r.bad_percent.at(2);
      row.bad_4 = r.bad_percent.at(3);
      row.coverage = 100.0 * r.coverage;
      rows.push_back(row);
    }
  }
  if (absl::Status s =
          WriteText(io, "metrics", "metrics/metrics.json", MetricsToJson(rows));
      !s.ok()) {
    return s;
  }
  {
    std::lock_guard<std::mutex> l(caller_mu_);
    if (absl::Status s = store_.RecordMetrics(rows); !s.ok()) return s;
  }
  metrics_ = rows;
  have_metrics_ = true;
  return absl::OkStatus();
}

absl::Status Runner::Export(StepIo& io) {
  absl::StatusOr<hdr::ExposureStack> stacks[2] = {Stack(0), Stack(1)};
  for (const auto& s : stacks) {
    if (!s.ok()) return s.status();
  }
  for (int v = 0; v < 2; ++v) {
    if (absl::Status s = Write(io, "export", absl::StrCat("im", v, ".png"),
                               stacks[v]->images[LdrIndex()]);
        !s.ok()) {
      return s;
    }
  }
  const cv::Size size = stacks[0]->images[0].size();
  absl::StatusOr<std::vector<Truth>> truths = Truths();
  if (!truths.ok()) return truths.status();
  if (truths->empty()) {
    Warn(absl::StrCat("export: no ground truth: no ", io::kDisparity0File,
                      " / ", io::kMask0File));
  } else {
    const Truth& t = truths->front();
    RETURN_IF_ERROR(io::WriteGroundTruth(dir_, t.disparity, t.mask0nocc));
    for (const char* name : {io::kDisparity0File, io::kMask0File}) {
      io.outputs.push_back({io.step, "export", name, io.params, "", 0});
    }
  }
  SessionInput::Intrinsics k;
  if (in_.intrinsics) {
    k = *in_.intrinsics;
  } else {
    // A nominal camera (horizontal field of view about 53 degrees) keeps
    // calib.txt parseable; depth from it is only indicative.
    k = {static_cast<double>(size.width), static_cast<double>(size.width),
         (size.width - 1) / 2.0, (size.height - 1) / 2.0};
    Warn(
        "export: camera intrinsics unknown: calib.txt has a nominal focal "
        "length (image width)");
  }
  ASSIGN_OR_RETURN(const int max_disp, MaxDisparity(size.width));
  io::Calib calib;
  calib.fx = k.fx;
  calib.fy = k.fy;
  calib.cx = k.cx;
  calib.cy = k.cy;
  calib.baseline_mm = in_.baseline_mm;
  calib.width = size.width;
  calib.height = size.height;
  calib.ndisp = max_disp + 1;
  return WriteOutput(
      io, "export", io::kCalibFile, "",
      [&](const fs::path& path) { return io::WriteCalib(path, calib); });
}

absl::Status Runner::Report(StepIo& io) {
  report::Page page;
  page.title = absl::StrCat("Session ", in_.session_name);
  for (const auto& kv : in_.capture_summary) page.summary.push_back(kv);
  absl::StatusOr<hdr::ExposureStack> stacks[2] = {Stack(0), Stack(1)};
  for (const auto& s : stacks) {
    if (!s.ok()) return s.status();
  }
  std::vector<std::string> tags;
  for (double e : stacks[0]->exposure_s) tags.push_back(ExposureTag(e));
  const cv::Size size = stacks[0]->images[0].size();
  absl::StatusOr<int> max_disp = MaxDisparity(size.width);
  if (!max_disp.ok()) return max_disp.status();
  page.summary.push_back({"exposures", absl::StrJoin(tags, ", ")});
  page.summary.push_back(
      {"baseline", absl::StrFormat("%.1f mm", in_.baseline_mm)});
  page.summary.push_back(
      {"frames",
       absl::StrCat(in_.frames.size(), " (",
                    sel_.stereo[0].size() + sel_.stereo[1].size(), " stereo, ",
                    sel_.sl.size(), " structured light)")});
  page.summary.push_back(
      {"image size", absl::StrCat(size.width, " x ", size.height)});
  page.summary.push_back({"disparity range", absl::StrCat("0 .. ", *max_disp)});
  absl::StatusOr<std::string> rect =
      io::ReadFileBytes(dir_ / "exposures/rectification.txt");
  if (rect.ok()) page.summary.push_back({"rectification", *rect});

  auto png = [&](const std::string& name, const cv::Mat& image,
                 const std::string& caption,
                 report::Section& section) -> absl::Status {
    if (absl::Status s =
            Write(io, "report", absl::StrCat("report/", name), To8Bit(image));
        !s.ok()) {
      return s;
    }
    section.figures.push_back({name, caption});
    return absl::OkStatus();
  };

  report::Section exposures{
      "Exposure stack", "Rectified, longest first.", {}, {}};
  for (int v = 0; v < 2; ++v) {
    for (size_t i = 0; i < stacks[v]->images.size(); ++i) {
      if (absl::Status s =
              png(absl::StrCat("exposure_", ViewName(v), "_", i, ".png"),
                  stacks[v]->images[i], absl::StrCat(ViewName(v), " ", tags[i]),
                  exposures);
          !s.ok()) {
        return s;
      }
    }
  }
  page.sections.push_back(std::move(exposures));

  report::Section preview{
      "HDR preview", "Left HDR radiance tone-mapped with Reinhard.", {}, {}};
  if (absl::Status s = CopyFile(io, "report", "tonemapped/reinhard/im0.png",
                                "report/hdr_preview.png");
      !s.ok()) {
    return s;
  }
  preview.figures.push_back({"hdr_preview.png", "HDR (reinhard)"});
  page.sections.push_back(std::move(preview));

  report::Section tmo{"Tone-mapped pairs", "", {}, {}};
  for (const std::string& op : OperatorNames()) {
    for (int v = 0; v < 2; ++v) {
      const std::string name =
          absl::StrCat("tonemapped_", op, "_im", v, ".png");
      if (absl::Status s = CopyFile(
              io, "report", absl::StrCat("tonemapped/", op, "/im", v, ".png"),
              absl::StrCat("report/", name));
          !s.ok()) {
        return s;
      }
      tmo.figures.push_back({name, absl::StrCat(op, " ", ViewName(v))});
    }
  }
  page.sections.push_back(std::move(tmo));

  absl::StatusOr<std::vector<Truth>> truths = Truths();
  if (!truths.ok()) return truths.status();
  report::Section gt{"Ground truth", "", {}, {}};
  if (truths->empty()) gt.text = "No ground truth for this session.";
  for (const Truth& t : *truths) {
    absl::StatusOr<cv::Mat> c =
        eval::ColorizeDisparity(t.disparity, 0, *max_disp);
    if (!c.ok()) return c.status();
    if (absl::Status s = png(absl::StrCat("gt_", t.name, ".png"), *c,
                             absl::StrCat(t.name, " disparity"), gt);
        !s.ok()) {
      return s;
    }
    cv::Mat invalid = t.mask0nocc == 0;
    if (absl::Status s =
            png(absl::StrCat("gt_", t.name, "_invalid.png"), invalid,
                absl::StrCat(t.name, " invalid (white)"), gt);
        !s.ok()) {
      return s;
    }
  }
  page.sections.push_back(std::move(gt));

  std::vector<std::string> methods = StereoMethods();
  for (const std::string& m : FusedMethods()) methods.push_back(m);
  report::Section disp{
      "Disparity", "Viridis over the disparity range.", {}, {}};
  report::Section err{"Error",
                      "|disparity - truth|, plasma over 0..4 px, "
                      "black where unknown.",
                      {},
                      {}};
  for (const std::string& m : methods) {
    absl::StatusOr<cv::Mat> d = ReadPfm(absl::StrCat("disparity/", m, ".pfm"));
    if (!d.ok()) return d.status();
    absl::StatusOr<cv::Mat> c = eval::ColorizeDisparity(*d, 0, *max_disp);
    if (!c.ok()) return c.status();
    if (absl::Status s = png(absl::StrCat("disp_", m, ".png"), *c, m, disp);
        !s.ok()) {
      return s;
    }
    for (const Truth& t : *truths) {
      absl::StatusOr<cv::Mat> e = eval::ColorizeError(
          *d, t.disparity, 4.0, options_.step_options.evaluation);
      if (!e.ok()) return e.status();
      if (absl::Status s = png(absl::StrCat("error_", t.name, "_", m, ".png"),
                               *e, absl::StrCat(m, " vs ", t.name), err);
          !s.ok()) {
        return s;
      }
    }
  }
  page.sections.push_back(std::move(disp));
  if (!truths->empty()) page.sections.push_back(std::move(err));

  report::Section table{"Metrics",
                        "Non-occluded pixels; bad-t = percent of scored "
                        "pixels with error > t px (or no estimate); sorted "
                        "by RMSE.",
                        {},
                        {}};
  absl::StatusOr<std::string> mj =
      io::ReadFileBytes(dir_ / "metrics/metrics.json");
  if (!mj.ok()) return mj.status();
  absl::StatusOr<std::vector<Metric>> rows = MetricsFromJson(*mj);
  if (!rows.ok()) return rows.status();
  std::stable_sort(rows->begin(), rows->end(),
                   [](const Metric& a, const Metric& b) {
                     return std::tie(a.ground_truth, a.rmse) <
                            std::tie(b.ground_truth, b.rmse);
                   });
  report::Table t{"metrics",
                  {"ground truth", "method", "RMSE", "MAE", "bad-0.5 %",
                   "bad-1 %", "bad-2 %", "bad-4 %", "coverage %"},
                  {}};
  for (const Metric& m : *rows) {
    t.rows.push_back(
        {m.ground_truth, m.method, absl::StrFormat("%.3f", m.rmse),
         absl::StrFormat("%.3f", m.mae), absl::StrFormat("%.1f", m.bad_0_5),
         absl::StrFormat("%.1f", m.bad_1), absl::StrFormat("%.1f", m.bad_2),
         absl::StrFormat("%.1f", m.bad_4),
         absl::StrFormat("%.1f", m.coverage)});
  }
  if (rows->empty()) table.text = "No metrics: no ground truth.";
  table.tables.push_back(std::move(t));
  page.sections.push_back(std::move(table));
  return WriteText(io, "report", "report/index.html", report::RenderPage(page));
}

// ------------------------------------------------------------ machinery

absl::Status Runner::Configure(StepIo& io) {
  const StepOptions& o = options_.step_options;
  const std::string& step = io.step;
  json params = json::object();
  if (step == "response") {
    params = o.response;
  } else if (step == "hdr") {
    params = o.merge;
  } else if (step == "tonemap") {
    params = {{"operators", OperatorNames()}, {"params", o.tonemap}};
  } else if (step == "sl_groundtruth") {
    params = {{"decode", o.sl_decode}, {"ground_truth", o.sl_ground_truth}};
    if (in_.projector_size) {
      params["projector"] = {in_.projector_size->first,
                             in_.projector_size->second};
    }
  } else if (step == "stereo" || step == "fusion") {
    absl::StatusOr<hdr::ExposureStack> left = Stack(0);
    if (!left.ok()) return left.status();
    absl::StatusOr<int> max_disp = MaxDisparity(left->images[0].cols);
    if (!max_disp.ok()) return max_disp.status();
    if (step == "stereo") {
      for (stereo::StereoOptions* s : {&io.ldr_stereo, &io.hdr_stereo}) {
        *s = s == &io.ldr_stereo ? o.ldr_stereo : o.hdr_stereo;
        s->max_disparity = *max_disp;
        // One thread per matching: the matchings themselves run in
        // parallel, and the result does not depend on the split.
        s->threads = 1;
      }
      params = {{"ldr", io.ldr_stereo},
                {"hdr", io.hdr_stereo},
                {"ldr_exposure_s", left->exposure_s[LdrIndex()]}};
    } else {
      io.fusion = o.fusion;
      io.fusion.max_disp = *max_disp;
      params = io.fusion;
    }
  } else if (step == "evaluate") {
    params = o.evaluation;
  } else if (step == "export") {
    params = {{"baseline_mm", in_.baseline_mm}, {"intrinsics", nullptr}};
    if (in_.intrinsics) {
      params["intrinsics"] = {in_.intrinsics->fx, in_.intrinsics->fy,
                              in_.intrinsics->cx, in_.intrinsics->cy};
    }
  } else if (step == "report") {
    // Everything the page shows that is not in an input file.
    std::string s = absl::StrCat(in_.session_name, "\n",
                                 absl::StrFormat("%.17g", in_.baseline_mm),
                                 "\n", in_.frames.size(), "\n");
    for (const auto& [k, v] : in_.capture_summary) {
      absl::StrAppend(&s, k, "\t", v, "\n");
    }
    params = {{"page", io::Sha256Hex(s)}, {"error_maps", o.evaluation}};
  }
  io.params = params.dump();
  return absl::OkStatus();
}

absl::StatusOr<std::vector<std::pair<std::string, std::string>>>
Runner::InputsOf(const std::string& step) {
  std::vector<std::pair<std::string, std::string>> out;
  auto frames = [&](const std::vector<FrameInput>& list) -> absl::Status {
    for (const FrameInput& f : list) {
      absl::StatusOr<std::string> sha = io::Sha256HexOfFile(dir_ / f.path);
      if (!sha.ok()) {
        return absl::FailedPreconditionError(
            absl::StrCat("frame ", f.path, ": ", sha.status().message()));
      }
      out.emplace_back(f.path, *sha);
    }
    return absl::OkStatus();
  };
  if (step == "decode") {
    for (int v = 0; v < 2; ++v) {
      if (absl::Status s = frames(sel_.stereo[v]); !s.ok()) return s;
    }
  } else if (step == "rectify") {
    for (int v = 0; v < 2; ++v) {
      if (absl::Status s = frames(sel_.calibration[v]); !s.ok()) return s;
    }
  } else if (step == "sl_groundtruth") {
    if (absl::Status s = frames(sel_.sl); !s.ok()) return s;
  }
  if (step == "stereo" || step == "fusion" || step == "evaluate" ||
      step == "export" || step == "report") {
    for (const std::string& rel :
         {in_.sim_truth_disparity, in_.sim_truth_nonoccluded}) {
      if (rel.empty()) continue;
      absl::StatusOr<std::string> sha = io::Sha256HexOfFile(dir_ / rel);
      if (!sha.ok()) {
        return absl::FailedPreconditionError(absl::StrCat(
            "simulator truth ", rel, ": ", sha.status().message()));
      }
      out.emplace_back(rel, *sha);
    }
  }
  std::lock_guard<std::mutex> l(outputs_mu_);
  for (const std::string& dep : StepDependencies(step)) {
    for (const Artifact& a : outputs_[dep]) {
      // Manifests name the upstream input hash, which may change while the
      // files do not.
      if (a.kind != "manifest") out.emplace_back(a.path, a.sha256);
    }
  }
  return out;
}

bool Runner::Verified(const std::vector<Artifact>& artifacts) {
  if (artifacts.empty()) return false;
  for (const Artifact& a : artifacts) {
    absl::StatusOr<std::string> sha = io::Sha256HexOfFile(dir_ / a.path);
    if (!sha.ok() || *sha != a.sha256) return false;
  }
  return true;
}

absl::Status Runner::ExecuteStep(const std::string& step) {
  if (absl::Status s = Checkpoint(); !s.ok()) return s;
  absl::StatusOr<std::vector<std::pair<std::string, std::string>>> inputs =
      InputsOf(step);
  if (!inputs.ok()) return inputs.status();
  StepIo io{step, "", {}, {}, {}, {}};
  if (absl::Status s = Configure(io); !s.ok()) return s;
  const std::string& params = io.params;
  std::string key = absl::StrCat(step, "\n", kVersion, "\n", params, "\n");
  for (const auto& [path, sha] : *inputs)
    absl::StrAppend(&key, path, " ", sha, "\n");
  const std::string hash = io::Sha256Hex(key);

  if (!options_.force) {
    std::vector<Artifact> earlier;
    {
      std::lock_guard<std::mutex> l(caller_mu_);
      earlier = store_.Lookup(step, hash);
    }
    if (Verified(earlier)) {
      if (step == "evaluate") {
        absl::StatusOr<std::string> text =
            io::ReadFileBytes(dir_ / "metrics/metrics.json");
        if (!text.ok()) return text.status();
        absl::StatusOr<std::vector<Metric>> m = MetricsFromJson(*text);
        if (!m.ok()) return m.status();
        metrics_ = *m;
        have_metrics_ = true;
      }
      Info(absl::StrCat(step, ": unchanged, reused"));
      std::lock_guard<std::mutex> l(outputs_mu_);
      outputs_[step] = std::move(earlier);
      reused_.push_back(step);
      return absl::OkStatus();
    }
  }

  static const std::map<std::string, StepFn>* fns =
      new std::map<std::string, StepFn>{
          {"decode", &Runner::Decode},
          {"rectify", &Runner::RectifyStep},
          {"response", &Runner::Response},
          {"hdr", &Runner::Hdr},
          {"tonemap", &Runner::Tonemap},
          {"sl_groundtruth", &Runner::SlGroundTruth},
          {"stereo", &Runner::Stereo},
          {"fusion", &Runner::Fusion},
          {"evaluate", &Runner::Evaluate},
          {"export", &Runner::Export},
          {"report", &Runner::Report},
      };
  Info(absl::StrCat(step, ": computing"));
  absl::Status s;
  try {
    s = (this->*fns->at(step))(io);
  } catch (const cv::Exception& e) {
    s = absl::InternalError(absl::StrCat(step, ": OpenCV: ", e.what()));
  }
  if (!s.ok()) return s;

  // The manifest: what the step read and wrote, so that a step without
  // outputs (no structured light) is remembered too.
  std::string manifest =
      absl::StrCat("{\n  \"step\": \"", step, "\",\n  \"version\": \"",
                   kVersion, "\",\n  \"input_hash\": \"", hash,
                   "\",\n  \"params\": ", params, ",\n  \"outputs\": [");
  for (size_t i = 0; i < io.outputs.size(); ++i) {
    Artifact& a = io.outputs[i];
    absl::StatusOr<std::string> sha = io::Sha256HexOfFile(dir_ / a.path);
    if (!sha.ok()) return sha.status();
    a.sha256 = *sha;
    std::error_code ec;
    a.size_bytes = static_cast<int64_t>(fs::file_size(dir_ / a.path, ec));
    absl::StrAppend(&manifest, i == 0 ? "\n" : ",\n", "    {\"path\": \"",
                    a.path, "\", \"sha256\": \"", a.sha256, "\"}");
  }
  absl::StrAppend(&manifest, "\n  ]\n}\n");
  if (absl::Status w = WriteText(
          io, "manifest", absl::StrCat("pipeline/", step, ".json"), manifest);
      !w.ok()) {
    return w;
  }
  Artifact& m = io.outputs.back();
  m.sha256 = io::Sha256Hex(manifest);
  m.size_bytes = static_cast<int64_t>(manifest.size());
  {
    std::lock_guard<std::mutex> l(caller_mu_);
    if (absl::Status r = store_.Record(step, hash, io.outputs); !r.ok()) {
      return r;
    }
  }
  std::lock_guard<std::mutex> l(outputs_mu_);
  outputs_[step] = std::move(io.outputs);
  computed_.push_back(step);
  return absl::OkStatus();
}

absl::Status Runner::Preflight(const std::vector<std::string>& steps) {
  auto wants = [&](const std::string& s) {
    return std::find(steps.begin(), steps.end(), s) != steps.end();
  };
  if (in_.frames.empty()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "session ", in_.session_name, " has no frames: nothing to process"));
  }
  int64_t stereo_id = -1, sl_id = -1, calib_id = -1;
  for (const FrameInput& f : in_.frames) {
    if (f.capture_kind == "bracketed_stereo" && f.role == "stereo") {
      stereo_id = std::max(stereo_id, f.capture_id);
    } else if (f.capture_kind == "structured_light") {
      sl_id = std::max(sl_id, f.capture_id);
    } else if (f.capture_kind == "calibration") {
      calib_id = std::max(calib_id, f.capture_id);
    }
  }
  for (const FrameInput& f : in_.frames) {
    if (f.view_index < 0 || f.view_index > 1) continue;
    const size_t v = static_cast<size_t>(f.view_index);
    if (f.capture_id == stereo_id && f.capture_kind == "bracketed_stereo" &&
        f.role == "stereo") {
      sel_.stereo[v].push_back(f);
    } else if (f.capture_id == sl_id && f.capture_kind == "structured_light") {
      sel_.sl.push_back(f);
      if (sel_.sl_view_folder[v].empty()) {
        absl::StatusOr<io::FramePath> path = io::ParseFramePath(f.path);
        if (!path.ok()) {
          return absl::FailedPreconditionError(path.status().message());
        }
        sel_.sl_view_folder[v] = path->view;
      }
    } else if (f.capture_id == calib_id && f.capture_kind == "calibration") {
      sel_.calibration[v].push_back(f);
    }
  }
  sel_.sl_capture = sl_id;
  for (auto& list : sel_.stereo) {
    std::stable_sort(list.begin(), list.end(),
                     [](const FrameInput& a, const FrameInput& b) {
                       return a.exposure_s > b.exposure_s;
                     });
  }
  for (auto& list : sel_.calibration) {
    std::sort(
        list.begin(), list.end(), [](const FrameInput& a, const FrameInput& b) {
          return fs::path(a.path).filename() < fs::path(b.path).filename();
        });
  }
  auto exists = [&](const std::string& rel, const std::string& what) {
    std::error_code ec;
    if (fs::is_regular_file(dir_ / rel, ec)) return absl::OkStatus();
    return absl::FailedPreconditionError(
        absl::StrCat(what, " ", rel, " is missing"));
  };
  if (wants("decode")) {
    if (stereo_id < 0) {
      return absl::FailedPreconditionError(absl::StrCat(
          "session ", in_.session_name,
          " has no stereo frames (no bracketed_stereo capture with "
          "captures/<id>/<view>/stereo/ frames)"));
    }
    for (int v = 0; v < 2; ++v) {
      if (sel_.stereo[v].size() < 2) {
        return absl::FailedPreconditionError(absl::StrFormat(
            "bracketed_stereo capture %d: the %s view has %d stereo frames; "
            "HDR needs at least 2 exposures per view",
            stereo_id, ViewName(v), sel_.stereo[v].size()));
      }
      for (const FrameInput& f : sel_.stereo[v]) {
        if (!(f.exposure_s > 0)) {
          return absl::FailedPreconditionError(
              absl::StrCat("frame ", f.path, " has no exposure time"));
        }
        if (absl::Status s = exists(f.path, "frame"); !s.ok()) return s;
      }
    }
    std::vector<double> e[2];
    for (int v = 0; v < 2; ++v) {
      for (const FrameInput& f : sel_.stereo[v]) e[v].push_back(f.exposure_s);
    }
    if (e[0] != e[1]) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "bracketed_stereo capture %d: left and right views have different "
          "exposures",
          stereo_id));
    }
    if (sel_.calibration[0].size() != sel_.calibration[1].size()) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "calibration capture %d: %d left and %d right poses", calib_id,
          sel_.calibration[0].size(), sel_.calibration[1].size()));
    }
  }
  if (wants("sl_groundtruth") && sl_id >= 0) {
    // Every pattern of every exposure of both views (capture_layout.h naming).
    for (int v = 0; v < 2; ++v) {
      if (sel_.sl_view_folder[v].empty()) {
        return absl::FailedPreconditionError(absl::StrFormat(
            "structured_light capture %d has no %s view", sl_id, ViewName(v)));
      }
    }
    std::map<std::string, std::set<std::string>> present[2];  // tag -> ids
    int bits[2] = {0, 0};  // column, row bit planes seen
    for (const FrameInput& f : sel_.sl) {
      if (absl::Status s = exists(f.path, "structured-light frame"); !s.ok()) {
        return s;
      }
      const bool has_inv = absl::EndsWith(f.pattern, "_inv");
      const std::string id =
          absl::StrCat(f.pattern, f.inverse && !has_inv ? "_inv" : "");
      present[f.view_index][ExposureTag(f.exposure_s)].insert(id);
      int bit = 0;
      if (std::sscanf(f.pattern.c_str(), "col_b%d", &bit) == 1) {
        bits[0] = std::max(bits[0], bit + 1);
      } else if (std::sscanf(f.pattern.c_str(), "row_b%d", &bit) == 1) {
        bits[1] = std::max(bits[1], bit + 1);
      }
    }
    const cv::Size psize =
        in_.projector_size
            ? cv::Size(in_.projector_size->first, in_.projector_size->second)
            : cv::Size(1 << bits[0], 1 << bits[1]);
    std::set<std::string> tags;
    for (const auto& p : present) {
      for (const auto& [tag, ids] : p) tags.insert(tag);
    }
    for (int v = 0; v < 2; ++v) {
      for (const std::string& tag : tags) {
        for (const structured_light::Pattern& p :
             structured_light::AllPatterns(psize)) {
          const std::string id = structured_light::FrameId(p);
          if (!present[v][tag].count(id)) {
            io::FrameKey key;
            key.role = io::FrameRole::kStructuredLight;
            key.exposure_s = io::ParseExposureTag(tag).value_or(0);
            key.pattern = p.Id();
            key.inverse = p.inverse;
            return absl::FailedPreconditionError(absl::StrFormat(
                "structured_light capture %d: %s view, exposure %s: bit "
                "plane %s is missing (%s.*)",
                sl_id, ViewName(v), tag, id,
                io::FrameStem(sl_id, sel_.sl_view_folder[v], key)));
          }
        }
      }
    }
  }
  if (!in_.sim_truth_disparity.empty()) {
    if (absl::Status s = exists(in_.sim_truth_disparity, "simulator truth");
        !s.ok()) {
      return s;
    }
  }
  if (!in_.sim_truth_nonoccluded.empty()) {
    if (absl::Status s = exists(in_.sim_truth_nonoccluded, "simulator truth");
        !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<RunSummary> Runner::Run() {
  absl::StatusOr<std::vector<std::string>> steps = ResolveSteps(options_.steps);
  if (!steps.ok()) return steps.status();
  if (absl::Status s = options_.step_options.Validate(); !s.ok()) return s;
  if (absl::Status s = Preflight(*steps); !s.ok()) return s;
  Info(absl::StrCat("steps: ", absl::StrJoin(*steps, ", ")));

  std::mutex mu;
  std::condition_variable cv;
  std::set<std::string> done, started;
  int running = 0;
  absl::Status first;
  std::vector<std::thread> threads;
  const int max_running = std::max(1, options_.threads);
  std::unique_lock<std::mutex> lock(mu);
  for (;;) {
    if (first.ok()) {
      for (const std::string& step : *steps) {
        if (running >= max_running) break;
        if (started.count(step)) continue;
        bool ready = true;
        for (const std::string& d : StepDependencies(step)) {
          ready = ready && done.count(d) > 0;
        }
        if (!ready) continue;
        started.insert(step);
        ++running;
        threads.emplace_back([&, step] {
          absl::Status s = ExecuteStep(step);
          std::lock_guard<std::mutex> l(mu);
          if (s.ok()) {
            done.insert(step);
          } else if (first.ok()) {
            first = s;
          }
          --running;
          cv.notify_all();
        });
      }
    }
    if (running == 0) break;
    cv.wait(lock);
  }
  lock.unlock();
  for (std::thread& t : threads) t.join();
  if (!first.ok()) return first;

  RunSummary summary;
  for (const std::string& step : *steps) {
    if (std::find(computed_.begin(), computed_.end(), step) !=
        computed_.end()) {
      summary.computed.push_back(step);
    } else {
      summary.reused.push_back(step);
    }
  }
  if (have_metrics_) summary.metrics = metrics_;
  if (std::find(steps->begin(), steps->end(), "report") != steps->end()) {
    summary.report_path = "report/index.html";
  }
  return summary;
}

}  // namespace

absl::Status StepOptions::Validate() const {
  RETURN_IF_ERROR(WithFieldPrefix("response", response.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("merge", merge.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("tonemap", tonemap.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("sl_decode", sl_decode.Validate()));
  RETURN_IF_ERROR(
      WithFieldPrefix("sl_ground_truth", sl_ground_truth.Validate()));
  // The disparity range and thread counts are the steps' (any valid value
  // stands in for them here).
  for (const auto& [name, stereo] :
       {std::pair{"ldr_stereo", ldr_stereo}, {"hdr_stereo", hdr_stereo}}) {
    stereo::StereoOptions s = stereo;
    s.max_disparity = s.min_disparity + 1;
    s.threads = 1;
    RETURN_IF_ERROR(WithFieldPrefix(name, s.Validate()));
  }
  fusion::FusionParams f = fusion;
  f.max_disp = 1;
  RETURN_IF_ERROR(WithFieldPrefix("fusion", f.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("evaluation", evaluation.Validate()));
  if (evaluation.thresholds != std::vector<double>{0.5, 1, 2, 4}) {
    return absl::InvalidArgumentError(
        "evaluation.thresholds must be {0.5, 1, 2, 4}: the metrics' "
        "bad-pixel columns");
  }
  return absl::OkStatus();
}

const std::vector<std::string>& AllSteps() {
  static const std::vector<std::string>* all = [] {
    auto* v = new std::vector<std::string>();
    for (const StepDef& d : Defs()) v->push_back(d.name);
    return v;
  }();
  return *all;
}

const std::vector<std::string>& StepDependencies(const std::string& step) {
  static const std::vector<std::string>* none = new std::vector<std::string>();
  for (const StepDef& d : Defs()) {
    if (d.name == step) return d.deps;
  }
  return *none;
}

absl::StatusOr<std::vector<std::string>> ResolveSteps(
    const std::vector<std::string>& requested) {
  if (requested.empty()) return AllSteps();
  std::set<std::string> wanted;
  std::vector<std::string> stack;
  for (const std::string& r : requested) {
    if (std::find(AllSteps().begin(), AllSteps().end(), r) ==
        AllSteps().end()) {
      return absl::InvalidArgumentError(
          absl::StrCat("unknown step \"", r,
                       "\"; known steps: ", absl::StrJoin(AllSteps(), ", ")));
    }
    stack.push_back(r);
  }
  while (!stack.empty()) {
    const std::string s = stack.back();
    stack.pop_back();
    if (!wanted.insert(s).second) continue;
    for (const std::string& d : StepDependencies(s)) stack.push_back(d);
  }
  std::vector<std::string> out;
  for (const std::string& s : AllSteps()) {
    if (wanted.count(s)) out.push_back(s);
  }
  return out;
}

absl::StatusOr<RunSummary> Run(const SessionInput& input,
                               const RunOptions& options, RunStore& store,
                               RunObserver& observer) {
  Runner runner(input, options, store, observer);
  return runner.Run();
}

}  // namespace hdrstereo::pipeline
