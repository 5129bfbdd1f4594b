// SPDX-License-Identifier: GPL-3.0-or-later
//
// Checks for sizes that untrusted input declares (a file's width, a peer's
// data length, a layout's frame count): every such number is compared with
// an explicit limit, with overflow-checked arithmetic, before anything is
// allocated or copied, and the error names the field, its value and the
// limit. Error messages quote what they received through QuoteInput, which
// keeps only a bounded, escaped prefix (QuoteInputTail: the end).
//
//   RETURN_IF_ERROR(CheckRange("PFM width", width, 1, kMaxImageSide));
//   ASSIGN_OR_RETURN(size_t bytes,
//                    ImageBytes("PFM", width, height, channels, 4));
#ifndef HDRSTEREO_PROCESSING_BASE_INPUT_LIMITS_H_
#define HDRSTEREO_PROCESSING_BASE_INPUT_LIMITS_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo {

// OpenCV's own limits for decoded images: imgcodecs reads them from the
// environment variables OPENCV_IO_MAX_IMAGE_WIDTH, _HEIGHT and _PIXELS
// (defaults 2^20, 2^20 and 2^30), and so do we, once per process, so that
// no reader of ours accepts an image OpenCV itself would refuse to decode,
// and one setting lowers both (the fuzz targets lower them to keep every
// allocation under libFuzzer's malloc limit).
struct ImageLimits {
  int64_t max_width;
  int64_t max_height;
  int64_t max_pixels;
};
const ImageLimits& DecodedImageLimits();
// One of those limits as an environment variable's value `text` sets it
// (nullptr: unset): a whole number above 0, at most `max` (a larger one is
// `max`: readers build cv::Mat sides from a width and a height, which are
// int, so those are at most INT_MAX); `fallback` when unset or not such a
// number.
int64_t ImageLimitFromEnv(const char* text, int64_t fallback, int64_t max);
// cv::Mat holds at most 512 channels (CV_CN_MAX).
inline constexpr int64_t kMaxImageChannels = 512;

// The largest frame buffer a display offers, each way (X11's and GPUs'
// largest framebuffer and texture side; an 8K projector is 8192 wide): the
// most a projector's size may be in a layout, a scene or a job request.
inline constexpr int kMaxProjectorSide = 16384;

// The longest name a file from others gives something (a step, a method, a
// scene object, a hash, a status code): names are short, and this bounds
// what a message or a lookup key holds (longer than a file name's 255).
inline constexpr size_t kMaxNameBytes = 256;

// The most bytes of received text an error message quotes.
inline constexpr size_t kMaxQuotedBytes = 64;

// `text` for an error message: at most `max_bytes` of it, C-escaped, in
// double quotes, followed by "... (N bytes)" when it was cut.
std::string QuoteInput(absl::string_view text,
                       size_t max_bytes = kMaxQuotedBytes);

// The end of `text`, for an error message about received text whose end is
// what matters (a failed command's output): at most `max_bytes` of it,
// C-escaped, in double quotes, preceded by "(N bytes left out) ..." when
// anything was cut, N counting `bytes_before`: bytes that came before
// `text` and were already dropped (e.g. by a reader that keeps a tail).
std::string QuoteInputTail(absl::string_view text, size_t max_bytes,
                           uint64_t bytes_before = 0);

// INVALID_ARGUMENT "<field>: <value> is outside [<min>, <max>]" unless
// min <= value <= max.
absl::Status CheckRange(absl::string_view field, int64_t value, int64_t min,
                        int64_t max);

// a * b; INVALID_ARGUMENT naming `what` when the
// product overflows 64 bits or exceeds `limit`.
absl::StatusOr<uint64_t> CheckedMultiply(absl::string_view what, uint64_t a,
                                         uint64_t b, uint64_t limit);

// The bytes of a width x height image of `channels` channels of
// `bytes_per_channel` bytes, after checking each against
// DecodedImageLimits() (INVALID_ARGUMENT naming `what`, the field, its value
// and the limit).
absl::StatusOr<size_t> ImageBytes(absl::string_view what, int64_t width,
                                  int64_t height, int64_t channels,
                                  int64_t bytes_per_channel);

}  // namespace hdrstereo

#endif  // HDRSTEREO_PROCESSING_BASE_INPUT_LIMITS_H_
