// SPDX-License-Identifier: GPL-3.0-or-later
// Camera frames as the daemon and hdrstereo-proc decode them. The first
// byte picks the format (the decoder goes by the file's extension, which a
// camera or another lab chooses), the rest is the file.
#include <opencv2/core.hpp>

#include "processing/base/input_limits.h"
#include "processing/io/image.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static constexpr const char* kExtensions[] = {".png", ".tif", ".jpg",
                                                ".pfm", ".exr", ".hdr"};
  const char* extension = kExtensions[data[0] % std::size(kExtensions)];
  absl::StatusOr<hdrstereo::io::DecodedImage> image =
      hdrstereo::io::DecodeImageBytes(
          hdrstereo::fuzz::AsText(data + 1, size - 1), extension);
  if (!image.ok()) return 0;
  const cv::Mat& pixels = image->pixels;
  FUZZ_CHECK(!pixels.empty());
  FUZZ_CHECK(pixels.depth() == CV_8U || pixels.depth() == CV_16U ||
             pixels.depth() == CV_32F);
  FUZZ_CHECK(pixels.channels() == 1 || pixels.channels() == 3);
  FUZZ_CHECK(static_cast<int64_t>(pixels.total()) <=
             hdrstereo::DecodedImageLimits().max_pixels);
  return 0;
}
