// SPDX-License-Identifier: GPL-3.0-or-later
//
// A small EXIF reader: exposure time, ISO, aperture and capture time from
// JPEG (APP1), TIFF (the file is itself a TIFF structure) and PNG (eXIf
// chunk); LibRaw's metadata for camera RAW files. And the writer the
// simulated camera uses to stamp its files like a real camera does.
#ifndef HDRSTEREO_PROCESSING_IO_EXIF_H_
#define HDRSTEREO_PROCESSING_IO_EXIF_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

struct ExifInfo {
  std::optional<double> exposure_s;  // ExposureTime (0x829A)
  // ISOSpeedRatings (0x8827), or where it is missing or saturated at 65535
  // the sensitivity SensitivityType (0x8830) names: EXIF 2.3's
  // RecommendedExposureIndex, ISOSpeed or StandardOutputSensitivity.
  std::optional<double> iso;
  std::optional<double> aperture;  // FNumber (0x829D)
  std::string camera;              // Make + Model
  // DateTimeOriginal (0x9003) as written, "YYYY:MM:DD HH:MM:SS" (the
  // camera's clock, no time zone), and SubSecTimeOriginal (0x9291) digits.
  std::string date_time_original;
  std::string subsec_time_original;
};

// `value` when it is a finite number above 0, else nullopt: how the readers
// keep a number (cameras write 0 for a field they do not know, e.g.
// ExposureTime 0/1000000; LibRaw passes on a RAW file's infinity or NaN).
std::optional<double> PositiveFinite(std::optional<double> value);

// DateTimeOriginal (+ SubSecTimeOriginal) read as UTC, in Unix milliseconds
// (the camera's clock has no zone: use it to compare frames of one camera,
// not as wall time). nullopt when absent or malformed.
std::optional<int64_t> ExifCaptureTimeMs(const ExifInfo& info);

// Parses a TIFF-structured EXIF block ("II*\0" or "MM\0*" header): IFD0
// and the Exif IFD it points to. Never fails: fields that cannot be read
// (or are 0) are left empty; every offset and count is checked against the
// block, strings are cut at 255 bytes and an IFD is read for at most 1000
// entries.
ExifInfo ParseExifTiff(absl::string_view tiff);

// Finds the EXIF block in a whole JPEG, TIFF or PNG file and parses it.
ExifInfo ParseExifFromFile(absl::string_view file_bytes);

// Camera RAW metadata: the EXIF of TIFF-based RAW files (DNG, CR2, NEF,
// ARW, ...), LibRaw's metadata (shutter, ISO, aperture, timestamp, make and
// model) for the others. Fields a camera wrote as 0 are left empty, as is
// everything of a file neither can read.
ExifInfo ReadRawMetadata(absl::string_view file_bytes);

// A little-endian EXIF block (TIFF structure: IFD0 with Model and the Exif
// sub-IFD with the fields of `info` that are set), as ParseExifTiff reads
// it back. ExposureTime is written as a rational with denominator 10^6 (or
// 1/n for exact fractions), FNumber with denominator 100, an ISO above
// 65535 as cameras write it (ISOSpeedRatings 65535, SensitivityType 2,
// RecommendedExposureIndex).
std::string EncodeExifTiff(const ExifInfo& info);

// `file_bytes` (a PNG or a JPEG) with the EXIF block `exif_tiff` added: an
// eXIf chunk after IHDR, or an APP1 segment after SOI. INVALID_ARGUMENT for
// other files or a block too large for a JPEG segment.
absl::StatusOr<std::string> EmbedExif(absl::string_view file_bytes,
                                      absl::string_view exif_tiff);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_EXIF_H_
