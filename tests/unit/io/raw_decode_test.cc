// SPDX-License-Identifier: GPL-3.0-or-later
//
// Camera RAW through LibRaw: a minimal DNG (RGGB mosaic, 14-bit white level)
// written with libtiff, decoded by DecodeRawFile. Linear output means a
// mosaic twice as bright decodes twice as bright (gamma 2.2 would give 1.37,
// auto-brightness would give 1).
#include <gtest/gtest.h>
#include <tiffio.h>

#include <cstdint>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"
#include "processing/io/image.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;

constexpr int kSize = 64;

// Writes a uniform-grey scene as an RGGB mosaic with per-site values.
bool WriteDng(const std::filesystem::path& path, uint16_t r, uint16_t g,
              uint16_t b) {
  TIFF* tif = TIFFOpen(path.c_str(), "w");
  if (tif == nullptr) return false;
  const uint8_t dng_version[4] = {1, 4, 0, 0};
  const uint8_t dng_backward[4] = {1, 1, 0, 0};
  const uint16_t cfa_dim[2] = {2, 2};
  const uint8_t cfa_pattern[4] = {0, 1, 1, 2};  // RGGB
  const float color_matrix[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const float neutral[3] = {1, 1, 1};
  const uint32_t white = 16383;
  bool ok = TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0) &&
            TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, kSize) &&
            TIFFSetField(tif, TIFFTAG_IMAGELENGTH, kSize) &&
            TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16) &&
            TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1) &&
            TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE) &&
            TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_CFA) &&
            TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) &&
            TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, kSize) &&
            TIFFSetField(tif, TIFFTAG_MAKE, "hdrstereo") &&
            TIFFSetField(tif, TIFFTAG_MODEL, "test") &&
            TIFFSetField(tif, TIFFTAG_DNGVERSION, dng_version) &&
            TIFFSetField(tif, TIFFTAG_DNGBACKWARDVERSION, dng_backward) &&
            TIFFSetField(tif, TIFFTAG_UNIQUECAMERAMODEL, "hdrstereo test") &&
            TIFFSetField(tif, TIFFTAG_CFAREPEATPATTERNDIM, cfa_dim) &&
            TIFFSetField(tif, TIFFTAG_CFAPATTERN, 4, cfa_pattern) &&
            TIFFSetField(tif, TIFFTAG_COLORMATRIX1, 9, color_matrix) &&
            TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT1, 21) &&
            TIFFSetField(tif, TIFFTAG_ASSHOTNEUTRAL, 3, neutral) &&
            TIFFSetField(tif, TIFFTAG_WHITELEVEL, 1, &white);
  std::vector<uint16_t> row(kSize);
  for (int y = 0; ok && y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      const bool even_y = y % 2 == 0, even_x = x % 2 == 0;
      row[x] = even_y && even_x ? r : (!even_y && !even_x ? b : g);
    }
    ok = TIFFWriteScanline(tif, row.data(), y, 0) == 1;
  }
  TIFFClose(tif);
  return ok;
}

TEST(RawDecodeTest, DngDecodesLinearWithoutAutoBrightness) {
  TempDir dir;
  ASSERT_TRUE(WriteDng(dir / "dim.dng", 1000, 1500, 800));
  ASSERT_TRUE(WriteDng(dir / "bright.dng", 2000, 3000, 1600));
  absl::StatusOr<DecodedImage> dim = DecodeImageFile(dir / "dim.dng");
  absl::StatusOr<DecodedImage> bright = DecodeImageFile(dir / "bright.dng");
  ASSERT_TRUE(dim.ok()) << dim.status();
  ASSERT_TRUE(bright.ok()) << bright.status();
  EXPECT_EQ(dim->pixels.type(), CV_16UC3);
  EXPECT_TRUE(dim->metadata.linear);
  EXPECT_TRUE(dim->metadata.white_balance.has_value());
  EXPECT_NE(dim->metadata.camera.find("hdrstereo"), std::string::npos);
  const cv::Rect centre(16, 16, 32, 32);
  const cv::Scalar a = cv::mean(dim->pixels(centre));
  const cv::Scalar b = cv::mean(bright->pixels(centre));
  for (int c = 0; c < 3; ++c) {
    ASSERT_GT(a[c], 100) << "channel " << c;
    EXPECT_NEAR(b[c] / a[c], 2.0, 0.02) << "channel " << c;
  }
}

// Sets the value of the SHORT or LONG entry `tag` of IFD0 of a
// little-endian TIFF.
void PatchTag(std::string& tiff, uint16_t tag, uint32_t value) {
  auto u16 = [&](size_t at) -> uint32_t {
    return static_cast<uint8_t>(tiff[at]) | static_cast<uint8_t>(tiff[at + 1])
                                                << 8;
  };
  ASSERT_EQ(tiff.substr(0, 2), "II");
  size_t ifd = 0;
  for (int i = 3; i >= 0; --i) {
    ifd = ifd << 8 | static_cast<uint8_t>(tiff[4 + i]);
  }
  for (uint32_t i = 0; i < u16(ifd); ++i) {
    const size_t at = ifd + 2 + 12 * i;
    if (u16(at) != tag) continue;
    for (int b = 0; b < (u16(at + 2) == 3 ? 2 : 4); ++b) {
      tiff[at + 8 + b] = static_cast<char>(value >> (8 * b));
    }
    return;
  }
  FAIL() << "no tag " << tag;
}

// A sensor of 40000 x 40000 pixels declared by a DNG of a few kB: each side
// within the limits, the area not; refused before LibRaw unpacks it.
TEST(RawDecodeTest, SensorSizesAboveTheLimitsAreRefusedBeforeUnpacking) {
  TempDir dir;
  ASSERT_TRUE(WriteDng(dir / "small.dng", 1000, 1500, 800));
  std::string dng = ReadFileOrDie(dir / "small.dng");
  PatchTag(dng, 256, 40000);  // ImageWidth
  PatchTag(dng, 257, 40000);  // ImageLength
  const std::string why = absl::StrCat(
      "RAW sensor pixels (width x height): 40000 x 40000 is "
      "more than the limit of ",
      DecodedImageLimits().max_pixels);
  EXPECT_THAT(DecodeRawBytes(dng), StatusIs(absl::StatusCode::kInvalidArgument,
                                            HasSubstr("(in memory): " + why)));
}

}  // namespace
}  // namespace hdrstereo::io
