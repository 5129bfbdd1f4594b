// SPDX-License-Identifier: GPL-3.0-or-later
// PFM files from other labs (Middlebury ground truth, disparities).
#include <opencv2/core.hpp>

#include "processing/io/hdr_formats.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  absl::StatusOr<cv::Mat> image =
      hdrstereo::io::ParsePfm(hdrstereo::fuzz::AsText(data, size));
  if (!image.ok()) return 0;
  FUZZ_CHECK(image->type() == CV_32FC1 || image->type() == CV_32FC3);
  // PFM stores its pixels uncompressed: an image the reader accepted must
  // have been in the file, all of it.
  FUZZ_CHECK(image->total() * image->elemSize() <= size);
  return 0;
}
