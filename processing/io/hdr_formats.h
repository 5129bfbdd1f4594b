// SPDX-License-Identifier: GPL-3.0-or-later
//
// Float and high-bit-depth image files. Every writer writes atomically
// (processing/io/atomic_file.h); every error names the file.
//
// Images are OpenCV-ordered (BGR for colour); the writers store RGB as each
// format expects and the readers return BGR again.
//
// The readers parse untrusted bytes: Parse* read from memory (errors say
// what is wrong, INVALID_ARGUMENT for a file that is not a valid image),
// Read* read a file and put its path before the error. Declared sizes are
// checked against DecodedImageLimits() (processing/base/input_limits.h)
// before anything is allocated.
#ifndef HDRSTEREO_PROCESSING_IO_HDR_FORMATS_H_
#define HDRSTEREO_PROCESSING_IO_HDR_FORMATS_H_

#include <filesystem>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// PFM, Middlebury convention: "PF" (3 channels) or "Pf" (1 channel), rows
// stored bottom-to-top, negative scale = little-endian (always written so).
// Accepts CV_32FC1 / CV_32FC3 (other depths are converted to float).
absl::Status WritePfm(const std::filesystem::path& path, const cv::Mat& image);
// The file must hold the width x height pixels its header declares.
absl::StatusOr<cv::Mat> ParsePfm(absl::string_view bytes);
absl::StatusOr<cv::Mat> ReadPfm(const std::filesystem::path& path);

// OpenEXR scanline file, channels R,G,B (or Y for one channel), ZIP
// compression. kHalf stores 16-bit floats, kFloat 32-bit.
enum class ExrPixelType { kHalf, kFloat };
absl::Status WriteExr(const std::filesystem::path& path, const cv::Mat& image,
                      ExrPixelType type = ExrPixelType::kHalf);
// Returns CV_32FC3 (BGR) or CV_32FC1 for a file with only a Y channel.
// Single-part, flat (not deep) files: the header's attributes must lie
// within the file, its data window and its chunks (tiles or blocks of scan
// lines, all channels as 4-byte values) within the image limits and at most
// the bytes of an RGBA float image of the limits' pixels, and a tiled
// file's offset table within the file.
absl::StatusOr<cv::Mat> ParseExr(absl::string_view bytes);
absl::StatusOr<cv::Mat> ReadExr(const std::filesystem::path& path);

// Radiance RGBE (.hdr). Colour (CV_32FC3) only; one channel is replicated.
absl::Status WriteRgbe(const std::filesystem::path& path, const cv::Mat& image);
// Reads Ward's format as his reference reader does (a "#?" first line,
// FORMAT=32-bit_rle_rgbe, "-Y H +X W", scanlines run-length encoded or
// flat), returning BGR. The size is checked against the image limits, and
// the data must be long enough to hold H such scanlines, before the image
// is allocated; every run stays inside its scanline.
absl::StatusOr<cv::Mat> ParseRgbe(absl::string_view bytes);
absl::StatusOr<cv::Mat> ReadRgbe(const std::filesystem::path& path);

// PNG: CV_8U or CV_16U, 1 or 3 channels, written as is.
absl::Status WritePng(const std::filesystem::path& path, const cv::Mat& image);

// Any image encoded by OpenCV (png, tif, jpg, ...) to a file, atomically.
absl::Status WriteEncoded(const std::filesystem::path& path,
                          const cv::Mat& image);

// Picks the writer by extension: .pfm, .exr (half), .hdr, otherwise
// WriteEncoded.
absl::Status WriteImage(const std::filesystem::path& path,
                        const cv::Mat& image);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_HDR_FORMATS_H_
