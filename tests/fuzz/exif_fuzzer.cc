// SPDX-License-Identifier: GPL-3.0-or-later
// The EXIF of camera frames (JPEG APP1, TIFF, PNG eXIf), which the daemon
// checks every frame against.
#include <cmath>

#include "processing/io/exif.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

void CheckRead(const hdrstereo::io::ExifInfo& info) {
  // The reader leaves out what it cannot read; what it reports is a number
  // a frame can be checked against.
  for (const std::optional<double>& value :
       {info.exposure_s, info.iso, info.aperture}) {
    FUZZ_CHECK(!value.has_value() || (std::isfinite(*value) && *value > 0));
  }
  (void)hdrstereo::io::ExifCaptureTimeMs(info);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view bytes = hdrstereo::fuzz::AsText(data, size);
  CheckRead(hdrstereo::io::ParseExifFromFile(bytes));
  CheckRead(hdrstereo::io::ParseExifTiff(bytes));
  return 0;
}
