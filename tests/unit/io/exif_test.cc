// SPDX-License-Identifier: GPL-3.0-or-later
//
// EXIF: the writer the simulated camera uses, read back by the reader the
// daemon verifies frames with; the reader on real camera files.
#include "processing/io/exif.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "tests/support/status_matchers.h"

namespace hdrstereo::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string Encoded(const char* ext) {
  cv::Mat img(6, 9, CV_8UC3, cv::Scalar(10, 120, 230));
  std::vector<uint8_t> buf;
  EXPECT_TRUE(cv::imencode(ext, img, buf));
  return std::string(buf.begin(), buf.end());
}

ExifInfo Sample() {
  ExifInfo info;
  info.exposure_s = 1.0 / 125;
  info.iso = 400;
  info.aperture = 5.6;
  info.camera = "hdrstereo sim";
  info.date_time_original = "2026:12:02 05:49:03";
  info.subsec_time_original = "042";
  return info;
}

TEST(ExifWriterTest, PngAndJpegCarryWhatWasWrittenAndStillDecode) {
  for (const char* ext : {".png", ".jpg"}) {
    ASSERT_OK_AND_ASSIGN(std::string stamped,
                         EmbedExif(Encoded(ext), EncodeExifTiff(Sample())));
    const ExifInfo read = ParseExifFromFile(stamped);
    EXPECT_DOUBLE_EQ(read.exposure_s.value_or(0), 1.0 / 125) << ext;
    EXPECT_DOUBLE_EQ(read.iso.value_or(0), 400) << ext;
    EXPECT_DOUBLE_EQ(read.aperture.value_or(0), 5.6) << ext;
    EXPECT_EQ(read.camera, "hdrstereo sim") << ext;
    EXPECT_EQ(read.date_time_original, "2026:12:02 05:49:03") << ext;
    EXPECT_EQ(read.subsec_time_original, "042") << ext;
    // 2026-12-02T05:49:03.042Z
    EXPECT_EQ(ExifCaptureTimeMs(read).value_or(0), 1796190543042) << ext;
    // The image itself is untouched (OpenCV checks the PNG chunk CRC).
    const cv::Mat decoded = cv::imdecode(
        cv::Mat(1, static_cast<int>(stamped.size()), CV_8UC1, stamped.data()),
        cv::IMREAD_COLOR);
    ASSERT_FALSE(decoded.empty()) << ext;
    EXPECT_EQ(decoded.cols, 9);
  }
}

TEST(ExifWriterTest, ExposuresThatAreNotFractionsSurvive) {
  for (double e : {1.0 / 8000, 1.0 / 3, 0.3, 2.5, 30.0}) {
    ExifInfo info;
    info.exposure_s = e;
    const ExifInfo read = ParseExifTiff(EncodeExifTiff(info));
    ASSERT_TRUE(read.exposure_s.has_value()) << e;
    EXPECT_NEAR(*read.exposure_s, e, 1e-6 * e) << e;
  }
}

TEST(ExifWriterTest, OtherFilesAreRefused) {
  EXPECT_THAT(EmbedExif("GIF89a....", EncodeExifTiff(Sample())),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("PNG and JPEG")));
  EXPECT_THAT(
      EmbedExif(Encoded(".jpg"), std::string(70000, 'x')),
      testing::StatusIs(absl::StatusCode::kInvalidArgument,
                        HasSubstr("does not fit in a JPEG APP1 segment")));
}

TEST(ExifTimeTest, MalformedStampsAreUnknown) {
  ExifInfo info;
  for (const char* bad : {"", "    :  :     :  :  ", "2026:13:02 05:49:03",
                          "2026-12-02 05:49:03"}) {
    info.date_time_original = bad;
    EXPECT_FALSE(ExifCaptureTimeMs(info).has_value()) << bad;
  }
  info.date_time_original = "2015:07:24 11:52:31";
  info.subsec_time_original = "5";  // a fraction: 0.5 s
  EXPECT_EQ(ExifCaptureTimeMs(info).value_or(0), 1437738751500);
}

// A real camera's JPEGs (Olympus TG-4): the README of the data folder states
// the exposures (1/1250, 1/320, 1/40 s), f/2.0 and ISO 100.
TEST(ExifRealDataTest, OlympusBracketReadsAsDocumented) {
  const fs::path dir =
      fs::path(HDRSTEREO_SHARED_DIR) / "data/unis-bracket-jpeg";
  if (!fs::exists(dir)) GTEST_SKIP() << dir << " is absent";
  const std::pair<const char*, double> files[] = {{"UNIS_EV-2.jpg", 1.0 / 1250},
                                                  {"UNIS_EV0.jpg", 1.0 / 320},
                                                  {"UNIS_EV2.jpg", 1.0 / 40}};
  for (const auto& [name, exposure] : files) {
    std::ifstream in(dir / name, std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    const ExifInfo info = ParseExifFromFile(bytes.str());
    EXPECT_NEAR(info.exposure_s.value_or(0), exposure, 1e-9) << name;
    EXPECT_NEAR(info.aperture.value_or(0), 2.0, 1e-9) << name;
    EXPECT_EQ(info.iso.value_or(0), 100) << name;
    EXPECT_THAT(info.camera, HasSubstr("TG-4")) << name;
    EXPECT_EQ(info.date_time_original.substr(0, 10), "2015:07:24") << name;
    EXPECT_TRUE(ExifCaptureTimeMs(info).has_value()) << name;
  }
}

// A real RAW frame through LibRaw: its README says the exposure fields are
// 0 (Magic Lantern wrote none), so they must read as unknown, not as 0.
TEST(ExifRealDataTest, RawWithoutExposureFieldsReadsAsUnknown) {
  const fs::path file =
      fs::path(HDRSTEREO_SHARED_DIR) / "data/raw-dng-canon550d/colorchart.dng";
  if (!fs::exists(file)) GTEST_SKIP() << file << " is absent";
  std::ifstream in(file, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  const ExifInfo info = ReadRawMetadata(bytes.str());
  EXPECT_FALSE(info.exposure_s.has_value());
  EXPECT_THAT(info.camera, HasSubstr("Canon"));
  EXPECT_FALSE(ReadRawMetadata("not a raw file").exposure_s.has_value());
}

}  // namespace
}  // namespace hdrstereo::io
