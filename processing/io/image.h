// SPDX-License-Identifier: GPL-3.0-or-later
//
// Decoding of camera frames: TIFF (8/16-bit), PNG, JPEG through OpenCV and
// camera RAW (CR2, NEF, DNG, ...) through LibRaw, with exposure metadata.
#ifndef HDRSTEREO_PROCESSING_IO_IMAGE_H_
#define HDRSTEREO_PROCESSING_IO_IMAGE_H_

#include <array>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// What LibRaw read of a RAW file's sensor data: the levels it scaled by
// and the part of the sensor it kept.
struct RawLevels {
  int black = 0;  // black level subtracted (the DNG's BlackLevel)
  int white = 0;  // saturation (the DNG's WhiteLevel)
  // The decoded image's place on the sensor (the DNG's ActiveArea):
  // columns and rows of the full raw frame.
  cv::Rect active_area;
  cv::Size sensor_size;     // the full raw frame, masked borders included
  std::string cfa_pattern;  // "RGGB" at the active area's top left
};

struct ImageMetadata {
  std::optional<double> exposure_s;  // shutter time in seconds
  std::optional<double> iso;
  std::optional<double> aperture;  // f-number
  std::string camera;              // make and model where known
  // True when pixel values are proportional to scene radiance (LibRaw
  // output); false for display-encoded files (JPEG, PNG, camera TIFF).
  bool linear = false;
  // Camera white-balance multipliers (R, G, B, G2) as LibRaw reports them
  // (and applied to the decoded RAW); empty for non-RAW files.
  std::optional<std::array<float, 4>> white_balance;
  std::optional<RawLevels> raw;  // RAW files only
};

struct DecodedImage {
  // BGR (or grey) in the file's own depth: CV_8U, CV_16U or CV_32F.
  cv::Mat pixels;
  ImageMetadata metadata;
};

// True for file extensions LibRaw decodes (cr2, cr3, nef, arw, dng, ...).
bool IsRawExtension(const std::filesystem::path& path);

// What the in-memory decoders' errors name as the source.
inline constexpr char kInMemory[] = "(in memory)";

// Decodes any supported file (float formats .pfm, .exr and .hdr through
// hdr_formats.h, as linear CV_32F). Errors (missing, unreadable, corrupt,
// unsupported) are returned as a status that names the file.
absl::StatusOr<DecodedImage> DecodeImageFile(const std::filesystem::path& path);
// The same for a file's bytes in memory, the format chosen by `extension`
// as DecodeImageFile chooses it by the file's (".png", ".PFM", ".nef", ...);
// errors name kInMemory. Declared dimensions are checked against
// DecodedImageLimits() (OpenCV's own check for the formats it decodes)
// before the pixels are allocated.
absl::StatusOr<DecodedImage> DecodeImageBytes(absl::string_view bytes,
                                              absl::string_view extension);

// Camera RAW through LibRaw: black level subtracted and scaled so that the
// white level is full scale, demosaiced, camera white balance, linear
// (gamma 1, no auto-brightness), 16-bit BGR, sRGB primaries; only the
// sensor's active area. metadata.raw says which levels and area were used.
// The sensor and the image must lie within DecodedImageLimits().
absl::StatusOr<DecodedImage> DecodeRawFile(const std::filesystem::path& path);
absl::StatusOr<DecodedImage> DecodeRawBytes(absl::string_view bytes);

// cv::imdecode of `bytes` (at most 2^31 - 1 of them, not copied; a JPEG,
// PNG or TIFF file, by its first bytes) with
// `flags`; INVALID_ARGUMENT "cannot decode ..." when OpenCV throws (as it
// does for dimensions above its limits) or decodes nothing.
absl::StatusOr<cv::Mat> DecodeWithOpenCv(absl::string_view bytes, int flags);

// `status` with "<source>: " before its message (OK stays OK): how the path
// readers name their file around the in-memory parsers.
absl::Status WithSource(absl::string_view source, const absl::Status& status);
template <typename T>
absl::StatusOr<T> WithSource(absl::string_view source,
                             absl::StatusOr<T> result) {
  if (result.ok()) return result;
  return WithSource(source, result.status());
}

// Scales integer images to float in [0, 1] (8-bit / 255, 16-bit / 65535);
// float images are returned converted to CV_32F unchanged.
cv::Mat ToFloat(const cv::Mat& pixels);
// The other way, for display and guides: 8-bit as is, 16-bit / 257, float
// [0, 1] x 255 (saturating).
cv::Mat To8Bit(const cv::Mat& pixels);

// Reads a whole file into memory.
absl::StatusOr<std::string> ReadFileBytes(const std::filesystem::path& path);

// The file's extension with its dot, lower-cased (".jpg" for "A.JPG"), as
// the decoders and writers choose a format by it.
std::string LowerExtension(const std::filesystem::path& path);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_IMAGE_H_
