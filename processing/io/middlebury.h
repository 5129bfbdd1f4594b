// SPDX-License-Identifier: GPL-3.0-or-later
//
// The one owner of the Middlebury stereo format (the 2014 data sets'
// layout, vision.middlebury.edu/stereo/data/scenes2014):
//
//   calib.txt      cam0=[fx 0 cx; 0 fy cy; 0 0 1]  (pixels)
//                  cam1=[...]  doffs=<px>  baseline=<mm>  width=  height=
//                  ndisp=<disparity levels>  (one key=value a line; extra
//                  keys of our own, such as left_stage_mm, may follow)
//   disp0GT.pfm    left-view disparity in pixels, float; +inf = unknown
//   disp1GT.pfm    the same for the right view (optional)
//   mask0nocc.png  8-bit: 255 non-occluded, 128 occluded, 0 unknown
//
// PFM as io::WritePfm writes it: "Pf", rows bottom to top, little endian.
// Disparities are positive: left pixel x matches right pixel x - d.
#ifndef HDRSTEREO_PROCESSING_IO_MIDDLEBURY_H_
#define HDRSTEREO_PROCESSING_IO_MIDDLEBURY_H_

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

inline constexpr char kCalibFile[] = "calib.txt";
inline constexpr char kDisparity0File[] = "disp0GT.pfm";
inline constexpr char kDisparity1File[] = "disp1GT.pfm";
inline constexpr char kMask0File[] = "mask0nocc.png";

// mask0nocc.png values.
inline constexpr uint8_t kMaskNonOccluded = 255;
inline constexpr uint8_t kMaskOccluded = 128;
inline constexpr uint8_t kMaskUnknown = 0;

// calib.txt. Both cameras share the intrinsics (a rectified pair).
struct Calib {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  double doffs = 0;                       // x difference of principal points
  double baseline_mm = 0;
  int width = 0, height = 0;
  int ndisp = 0;  // disparity levels: a bound on the largest disparity
  // Keys of our own after the standard ones, in this order.
  std::vector<std::pair<std::string, std::string>> extra;
};

// The file's text: cam0, cam1, doffs, baseline, width, height, ndisp, then
// `extra`; every number in the fewest digits that read back as the same
// number, so that what ParseCalib accepts is written so that it reads back
// the same.
std::string FormatCalib(const Calib& calib);
// INVALID_ARGUMENT naming the key that is missing or unreadable (cam0,
// baseline, width, height, ndisp; doffs defaults to 0) and quoting a bounded
// prefix of its value; unknown keys are kept in `extra`. Numbers must be
// finite (vmin and vmax too, where present), width and height within
// DecodedImageLimits() (processing/base/input_limits.h), ndisp at most its
// largest width.
absl::StatusOr<Calib> ParseCalib(absl::string_view text);
// Written atomically. Read: NOT_FOUND for a missing file, the parse error
// prefixed with the path otherwise.
absl::Status WriteCalib(const std::filesystem::path& path, const Calib& calib);
absl::StatusOr<Calib> ReadCalib(const std::filesystem::path& path);

// The mask from a left-view truth: unknown where `disparity` is not finite,
// non-occluded where it is and `nonoccluded` is set (empty = everywhere),
// occluded elsewhere. CV_8UC1.
cv::Mat MaskFromTruth(const cv::Mat& disparity, const cv::Mat& nonoccluded);

// Writes disp0GT.pfm, mask0nocc.png and, when `disp1` is not empty,
// disp1GT.pfm into `dir` (created if missing), each atomically.
// INVALID_ARGUMENT when the maps are not CV_32FC1 / CV_8UC1 of one size.
absl::Status WriteGroundTruth(const std::filesystem::path& dir,
                              const cv::Mat& disp0, const cv::Mat& mask0nocc,
                              const cv::Mat& disp1 = cv::Mat());

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_MIDDLEBURY_H_
