// SPDX-License-Identifier: GPL-3.0-or-later
// Camera RAW metadata (TIFF-based RAW files through our EXIF reader, the
// others through LibRaw).
#include <cmath>

#include "processing/io/exif.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const hdrstereo::io::ExifInfo info =
      hdrstereo::io::ReadRawMetadata(hdrstereo::fuzz::AsText(data, size));
  for (const std::optional<double>& value :
       {info.exposure_s, info.iso, info.aperture}) {
    FUZZ_CHECK(!value.has_value() || (std::isfinite(*value) && *value > 0));
  }
  return 0;
}
