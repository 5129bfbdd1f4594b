// SPDX-License-Identifier: GPL-3.0-or-later
//
// Reading structured-light frames in the capture layout
// (processing/io/capture_layout.h):
//   <capture>/<view>/structured_light/sl_<col|row>_bNN[_inv]_exp_<tag>.<ext>
//   <capture>/<view>/structured_light/sl_<white|black>_exp_<tag>.<ext>
// in any image format io::DecodeImageFile reads (8- or 16-bit).
#ifndef HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_CAPTURE_IO_H_
#define HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_CAPTURE_IO_H_

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "processing/structured_light/decode.h"

namespace hdrstereo::structured_light {

// Loads every exposure of `view` ("left", "right", "view0", ...), sorted by
// exposure time, colour frames made grey (cv::COLOR_BGR2GRAY, as Decode
// would). Without `projector_size` the projector is taken as
// 2^column_bits x 2^row_bits (codes beyond the real width never occur).
// Errors name the folder and the missing or unreadable frame, e.g.
// "captures/7/left/structured_light: exposure 1-30s: sl_col_b03_inv is
// missing".
absl::StatusOr<ViewFrames> LoadCaptureView(
    const std::filesystem::path& capture_dir, const std::string& view,
    std::optional<cv::Size> projector_size = std::nullopt);

}  // namespace hdrstereo::structured_light

#endif  // HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_CAPTURE_IO_H_
