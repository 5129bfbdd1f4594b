// SPDX-License-Identifier: GPL-3.0-or-later
//
// A small EXIF reader: exposure time, ISO and aperture from JPEG (APP1),
// TIFF (the file is itself a TIFF structure) and PNG (eXIf chunk).
#ifndef HDRSTEREO_PROCESSING_IO_EXIF_H_
#define HDRSTEREO_PROCESSING_IO_EXIF_H_

#include <optional>
#include <string>

#include "absl/strings/string_view.h"

namespace hdrstereo::io {

struct ExifInfo {
  std::optional<double> exposure_s;  // ExposureTime (0x829A)
  std::optional<double> iso;         // ISOSpeedRatings (0x8827)
  std::optional<double> aperture;    // FNumber (0x829D)
  std::string camera;                // Make + Model
};

// Parses a TIFF-structured EXIF block ("II*\0" or "MM\0*" header). Never
// fails: fields that cannot be read are left empty.
ExifInfo ParseExifTiff(absl::string_view tiff);

// Finds the EXIF block in a whole JPEG, TIFF or PNG file and parses it.
ExifInfo ParseExifFromFile(absl::string_view file_bytes);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_EXIF_H_
