// SPDX-License-Identifier: GPL-3.0-or-later
// Middlebury calib.txt files from other labs.
#include "processing/io/middlebury.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  absl::StatusOr<hdrstereo::io::Calib> calib =
      hdrstereo::io::ParseCalib(hdrstereo::fuzz::AsText(data, size));
  if (!calib.ok()) return 0;
  // What the reader accepts, the writer writes so that the reader accepts
  // it again, and writing that gives the same text.
  const std::string text = hdrstereo::io::FormatCalib(*calib);
  absl::StatusOr<hdrstereo::io::Calib> again = hdrstereo::io::ParseCalib(text);
  FUZZ_CHECK(again.ok());
  FUZZ_CHECK(hdrstereo::io::FormatCalib(*again) == text);
  return 0;
}
