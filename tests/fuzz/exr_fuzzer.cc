// SPDX-License-Identifier: GPL-3.0-or-later
// OpenEXR radiance maps from other tools.
#include <opencv2/core.hpp>

#include "processing/base/input_limits.h"
#include "processing/io/hdr_formats.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  absl::StatusOr<cv::Mat> image =
      hdrstereo::io::ParseExr(hdrstereo::fuzz::AsText(data, size));
  if (!image.ok()) return 0;
  FUZZ_CHECK(image->type() == CV_32FC1 || image->type() == CV_32FC3);
  FUZZ_CHECK(static_cast<int64_t>(image->total()) <=
             hdrstereo::DecodedImageLimits().max_pixels);
  return 0;
}
