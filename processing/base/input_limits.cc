// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/base/input_limits.h"

#include <algorithm>
#include <cstdlib>
#include <limits>

#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo {

int64_t ImageLimitFromEnv(const char* text, int64_t fallback, int64_t max) {
  int64_t value = 0;
  if (text == nullptr || !absl::SimpleAtoi(text, &value) || value <= 0) {
    return fallback;
  }
  return std::min(value, max);
}

const ImageLimits& DecodedImageLimits() {
  constexpr int64_t kIntMax = std::numeric_limits<int>::max();
  static const ImageLimits limits = {
      ImageLimitFromEnv(std::getenv("OPENCV_IO_MAX_IMAGE_WIDTH"),
                        int64_t{1} << 20, kIntMax),
      ImageLimitFromEnv(std::getenv("OPENCV_IO_MAX_IMAGE_HEIGHT"),
                        int64_t{1} << 20, kIntMax),
      ImageLimitFromEnv(std::getenv("OPENCV_IO_MAX_IMAGE_PIXELS"),
                        int64_t{1} << 30, std::numeric_limits<int64_t>::max())};
  return limits;
}

std::string QuoteInput(absl::string_view text, size_t max_bytes) {
  if (text.size() <= max_bytes) {
    return absl::StrCat("\"", absl::CHexEscape(text), "\"");
  }
  return absl::StrCat("\"", absl::CHexEscape(text.substr(0, max_bytes)),
                      "\"... (", text.size(), " bytes)");
}

std::string QuoteInputTail(absl::string_view text, size_t max_bytes,
                           uint64_t bytes_before) {
  const size_t cut = text.size() > max_bytes ? text.size() - max_bytes : 0;
  const std::string quoted =
      absl::StrCat("\"", absl::CHexEscape(text.substr(cut)), "\"");
  if (cut == 0 && bytes_before == 0) return quoted;
  return absl::StrCat("(", bytes_before + cut, " bytes left out) ...", quoted);
}

absl::Status CheckRange(absl::string_view field, int64_t value, int64_t min,
                        int64_t max) {
  if (value < min || value > max) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", value, " is outside [", min, ", ", max, "]"));
  }
  return absl::OkStatus();
}

absl::StatusOr<uint64_t> CheckedMultiply(absl::string_view what, uint64_t a,
                                         uint64_t b, uint64_t limit) {
  uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product) || product > limit) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, ": ", a, " x ", b, " is more than the limit of ", limit));
  }
  return product;
}

absl::StatusOr<size_t> ImageBytes(absl::string_view what, int64_t width,
                                  int64_t height, int64_t channels,
                                  int64_t bytes_per_channel) {
  const ImageLimits& limits = DecodedImageLimits();
  RETURN_IF_ERROR(
      CheckRange(absl::StrCat(what, " width"), width, 1, limits.max_width));
  RETURN_IF_ERROR(
      CheckRange(absl::StrCat(what, " height"), height, 1, limits.max_height));
  RETURN_IF_ERROR(CheckRange(absl::StrCat(what, " channels"), channels, 1,
                             kMaxImageChannels));
  RETURN_IF_ERROR(CheckRange(absl::StrCat(what, " bytes per channel"),
                             bytes_per_channel, 1, 8));
  ASSIGN_OR_RETURN(
      uint64_t pixels,
      CheckedMultiply(absl::StrCat(what, " pixels (width x height)"), width,
                      height, limits.max_pixels));
  ASSIGN_OR_RETURN(uint64_t values,
                   CheckedMultiply(absl::StrCat(what, " values"), pixels,
                                   channels, UINT64_MAX));
  ASSIGN_OR_RETURN(uint64_t bytes,
                   CheckedMultiply(absl::StrCat(what, " bytes"), values,
                                   bytes_per_channel, SIZE_MAX));
  return static_cast<size_t>(bytes);
}

}  // namespace hdrstereo
