// SPDX-License-Identifier: GPL-3.0-or-later
//
// sl_groundtruth: the latest structured-light capture decoded per view and
// turned into a Middlebury ground truth in ground_truth/structured_light/
// (nothing, with a warning, without such a capture).
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/io/capture_layout.h"
#include "processing/io/middlebury.h"
#include "processing/pipeline/steps.h"
#include "processing/structured_light/capture_io.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/ground_truth.h"

namespace hdrstereo::pipeline {
namespace {

namespace sl = structured_light;

struct Options {
  std::optional<cv::Size> projector;  // else from the bit planes
  sl::DecodeOptions decode;
  sl::GroundTruthOptions ground_truth;
};

absl::Status Run(const Options& o, StepContext& c) {
  if (c.frames().structured_light.empty()) {
    c.Warn(
        "sl_groundtruth: the session has no structured-light capture: no "
        "structured-light ground truth");
    return absl::OkStatus();
  }
  const std::filesystem::path capture =
      c.dir() / io::CaptureDir(c.frames().structured_light_capture);
  sl::DecodedView decoded[2];
  RETURN_IF_ERROR(c.ParallelFor(
      {"decode left", "decode right"},
      [&](int v, StepOutputs&) -> absl::Status {
        absl::StatusOr<sl::ViewFrames> frames = sl::LoadCaptureView(
            capture, c.frames().structured_light_view[v], o.projector);
        if (!frames.ok()) {
          return absl::FailedPreconditionError(frames.status().message());
        }
        ASSIGN_OR_RETURN(decoded[v], sl::Decode(*frames, o.decode));
        return absl::OkStatus();
      },
      // One view at a time: a view's frames are the step's largest memory
      // (2 GB at 24 megapixels), and the step runs beside the stereo
      // frames' steps, which take longer.
      /*max_at_once=*/1));
  for (int v = 0; v < 2; ++v) {
    for (const std::string& w : decoded[v].warnings) {
      c.Warn(absl::StrCat("sl_groundtruth: ", io::ViewName(v), ": ", w));
    }
  }
  ASSIGN_OR_RETURN(
      const sl::GroundTruth gt,
      sl::ComputeGroundTruth(decoded[0], decoded[1], o.ground_truth));
  for (const std::string& w : gt.warnings) {
    c.Warn(absl::StrCat("sl_groundtruth: ", w));
  }
  RETURN_IF_ERROR(sl::WriteMiddlebury(gt, c.dir() / kStructuredLightDir));
  for (const char* name : {io::kDisparity0File, io::kDisparity1File,
                           io::kMask0File, sl::kStatsFile}) {
    c.outputs().Record("ground_truth",
                       absl::StrCat(kStructuredLightDir, "/", name));
  }
  c.Progress(3, 3, "sl_groundtruth: ground truth");
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureStructuredLight(const StepContext& c) {
  Options o;
  if (c.input().projector_size) {
    o.projector = cv::Size(c.input().projector_size->first,
                           c.input().projector_size->second);
  }
  o.decode = c.options().sl_decode;
  o.ground_truth = c.options().sl_ground_truth;
  nlohmann::json params = {{"decode", o.decode},
                           {"ground_truth", o.ground_truth}};
  if (o.projector)
    params["projector"] = {o.projector->width, o.projector->height};
  return ConfiguredStep{params, [o](StepContext& c) { return Run(o, c); }};
}

}  // namespace hdrstereo::pipeline
