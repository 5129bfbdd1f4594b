// SPDX-License-Identifier: GPL-3.0-or-later
//
// An exposure stack: images of one still view at different shutter times.
#ifndef HDRSTEREO_PROCESSING_HDR_STACK_H_
#define HDRSTEREO_PROCESSING_HDR_STACK_H_

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::hdr {

struct ExposureStack {
  std::vector<cv::Mat> images;     // same size, type and channel count
  std::vector<double> exposure_s;  // shutter time of each image, > 0
  std::vector<std::string> names;  // for messages (file names); optional
  std::string camera;              // from metadata where known

  // The name used in messages for image i ("exposure #i" without names).
  std::string Name(size_t i) const;
};

// Checks that the stack can be merged: at least two exposures, one time per
// image, every time finite and > 0, every image non-empty with the first's
// size, depth and channels (1 or 3). Errors name the offending file.
absl::Status ValidateStack(const ExposureStack& stack);

// Loads a stack folder: image files plus "exposures.txt" with one
// "<file name> <seconds>" per line (seconds may be written 1/250; '#'
// starts a comment); without exposures.txt, every image file in the folder
// is used and its exposure time is read from EXIF/RAW metadata. Images are
// ordered by exposure time, longest first. The result is validated.
absl::StatusOr<ExposureStack> LoadStack(const std::filesystem::path& dir);

struct StackImage {
  cv::Mat image;
  double exposure_s = 0;
};
// The image LoadStack(dir) puts at `index` (longest exposure first) and
// its exposure time. Where exposures.txt gives every time, only that file
// is decoded (the rest of the stack is neither read nor validated);
// otherwise the whole stack is loaded. INVALID_ARGUMENT when the stack has
// no such image.
absl::StatusOr<StackImage> LoadStackImage(const std::filesystem::path& dir,
                                          size_t index);

// Parses "1/250", "0.004" or "4e-3" as seconds.
absl::StatusOr<double> ParseSeconds(const std::string& text);

}  // namespace hdrstereo::hdr

#endif  // HDRSTEREO_PROCESSING_HDR_STACK_H_
