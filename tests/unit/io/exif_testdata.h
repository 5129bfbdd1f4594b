// SPDX-License-Identifier: GPL-3.0-or-later
//
// Hand-built EXIF test data: a JPEG carrying ExposureTime, FNumber, ISO and
// Make, to test metadata reading against known values.
#ifndef HDRSTEREO_TESTS_UNIT_IO_EXIF_TESTDATA_H_
#define HDRSTEREO_TESTS_UNIT_IO_EXIF_TESTDATA_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace hdrstereo::testing {

// A little-endian EXIF (TIFF) block: Make "Nikon", ExposureTime
// 1/`denominator`, FNumber 5.6, ISO 200.
inline std::string ExifBlock(uint32_t denominator = 250) {
  std::string t;
  auto u16 = [&](uint32_t v) {
    t.push_back(static_cast<char>(v));
    t.push_back(static_cast<char>(v >> 8));
  };
  auto u32 = [&](uint32_t v) {
    u16(v & 0xFFFF);
    u16(v >> 16);
  };
  t += "II";
  u16(42);
  u32(8);
  u16(2);  // IFD0 at 8
  u16(0x010F), u16(2), u32(6), u32(38);
  u16(0x8769), u16(4), u32(1), u32(44);
  u32(0);
  t += std::string("Nikon\0", 6);  // at 38
  u16(3);                          // Exif IFD at 44
  u16(0x829A), u16(5), u32(1), u32(86);
  u16(0x829D), u16(5), u32(1), u32(94);
  u16(0x8827), u16(3), u32(1), u32(200);
  u32(0);
  u32(1), u32(denominator);  // at 86
  u32(56), u32(10);          // at 94
  return t;
}

// `image` encoded as JPEG with ExifBlock(denominator) in an APP1 segment.
inline std::string JpegWithExif(const cv::Mat& image, uint32_t denominator) {
  std::vector<uchar> jpg;
  cv::imencode(".jpg", image, jpg);
  const std::string exif = ExifBlock(denominator);
  std::string app1 = "\xFF\xE1";
  const size_t len = 2 + 6 + exif.size();
  app1.push_back(static_cast<char>(len >> 8));
  app1.push_back(static_cast<char>(len & 0xFF));
  app1 += std::string("Exif\0\0", 6) + exif;
  std::string file(reinterpret_cast<const char*>(jpg.data()), jpg.size());
  file.insert(2, app1);
  return file;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_UNIT_IO_EXIF_TESTDATA_H_
