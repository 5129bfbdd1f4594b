// SPDX-License-Identifier: GPL-3.0-or-later
//
// Which of a session's frames the pipeline reads, and the checks made
// before any step runs (so that bad input writes and deletes nothing):
// the latest capture of each kind is used; views 0 (left) and 1 (right).
#ifndef HDRSTEREO_PROCESSING_PIPELINE_FRAME_SELECTION_H_
#define HDRSTEREO_PROCESSING_PIPELINE_FRAME_SELECTION_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "processing/pipeline/pipeline.h"

namespace hdrstereo::pipeline {

struct FrameSelection {
  // The latest bracketed-stereo capture's stereo frames, longest exposure
  // first (ambient frames are not used).
  std::vector<FrameInput> stereo[2];
  // The latest calibration capture's poses, by file name.
  std::vector<FrameInput> calibration[2];
  // The latest structured-light capture's frames, both views.
  std::vector<FrameInput> structured_light;
  int64_t stereo_capture = -1;  // -1 = none
  int64_t calibration_capture = -1;
  int64_t structured_light_capture = -1;
  // The view folders of the structured-light capture ("left", "view0").
  std::string structured_light_view[2];
};

// FAILED_PRECONDITION when the session has no frames or a structured-light
// frame lies outside the capture layout.
absl::StatusOr<FrameSelection> SelectFrames(const SessionInput& input);

// What `steps` need is there, else FAILED_PRECONDITION naming it: stereo
// frames of both views (>= 2 exposures, the same in both, each with an
// exposure time and on disk) and paired calibration poses for decode;
// every bit plane of every exposure of both views for sl_groundtruth; the
// simulator truth files named by `input`.
absl::Status CheckSelection(const FrameSelection& frames,
                            const SessionInput& input,
                            const std::vector<std::string>& steps);

}  // namespace hdrstereo::pipeline

#endif  // HDRSTEREO_PROCESSING_PIPELINE_FRAME_SELECTION_H_
