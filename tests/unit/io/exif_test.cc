// SPDX-License-Identifier: GPL-3.0-or-later
//
// EXIF: the writer the simulated camera uses, read back by the reader the
// daemon verifies frames with; the reader on real camera files.
#include "processing/io/exif.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

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

// A little-endian TIFF built by hand: IFD0 of `ifd0` entries at 8, then the
// bytes of `tail`. Each entry is (tag, type, count, value or offset).
struct RawEntry {
  uint16_t tag, type;
  uint32_t count, value;
};
std::string Le16(uint32_t v) {
  return {static_cast<char>(v), static_cast<char>(v >> 8)};
}
std::string Le32(uint32_t v) { return Le16(v & 0xFFFF) + Le16(v >> 16); }
std::string Ifd(const std::vector<RawEntry>& entries, uint32_t next = 0) {
  std::string out = Le16(static_cast<uint32_t>(entries.size()));
  for (const RawEntry& e : entries) {
    out += Le16(e.tag) + Le16(e.type) + Le32(e.count) + Le32(e.value);
  }
  return out + Le32(next);
}
std::string Tiff(const std::vector<RawEntry>& ifd0,
                 const std::string& tail = "") {
  return "II" + Le16(42) + Le32(8) + Ifd(ifd0) + tail;
}
// Up to 4 bytes of ASCII (with its NUL) as an inline entry value.
uint32_t Le32ValueOf(const std::string& text) {
  uint32_t v = 0;
  for (size_t i = 0; i < text.size() && i < 4; ++i) {
    v |= static_cast<uint32_t>(static_cast<uint8_t>(text[i])) << (8 * i);
  }
  return v;
}
// Where the bytes after IFD0 of `n` entries begin.
uint32_t AfterIfd0(size_t n) {
  return static_cast<uint32_t>(8 + 2 + 12 * n + 4);
}

// EXIF 2.3: a camera writes ISO 204800 as ISOSpeedRatings 65535,
// SensitivityType 2 (REI) and RecommendedExposureIndex 204800 (a LONG).
TEST(ExifIsoTest, IsoAbove65535IsReadFromTheTagSensitivityTypeNames) {
  const uint32_t exif_ifd = AfterIfd0(1);
  const std::string rei = Tiff(
      {{0x8769, 4, 1, exif_ifd}},
      Ifd({{0x8827, 3, 1, 65535}, {0x8830, 3, 1, 2}, {0x8832, 4, 1, 204800}}));
  EXPECT_EQ(ParseExifTiff(rei).iso.value_or(0), 204800);
  // SensitivityType 3: ISOSpeed (0x8833).
  const std::string speed = Tiff(
      {{0x8769, 4, 1, exif_ifd}},
      Ifd({{0x8827, 3, 1, 65535}, {0x8830, 3, 1, 3}, {0x8833, 4, 1, 102400}}));
  EXPECT_EQ(ParseExifTiff(speed).iso.value_or(0), 102400);
  // SensitivityType 1 (SOS) names StandardOutputSensitivity, not the REI.
  const std::string sos =
      Tiff({{0x8769, 4, 1, exif_ifd}}, Ifd({{0x8827, 3, 1, 65535},
                                            {0x8830, 3, 1, 1},
                                            {0x8831, 4, 1, 80000},
                                            {0x8832, 4, 1, 90000}}));
  EXPECT_EQ(ParseExifTiff(sos).iso.value_or(0), 80000);
  // No SensitivityType and no ISOSpeedRatings: the REI still counts.
  const std::string bare =
      Tiff({{0x8769, 4, 1, exif_ifd}}, Ifd({{0x8832, 4, 1, 409600}}));
  EXPECT_EQ(ParseExifTiff(bare).iso.value_or(0), 409600);
  // Below saturation ISOSpeedRatings is the ISO, as before.
  const std::string low = Tiff(
      {{0x8769, 4, 1, exif_ifd}},
      Ifd({{0x8827, 3, 1, 3200}, {0x8830, 3, 1, 2}, {0x8832, 4, 1, 3200}}));
  EXPECT_EQ(ParseExifTiff(low).iso.value_or(0), 3200);
  // Saturated with nothing else: 65535 is all the file says.
  const std::string only =
      Tiff({{0x8769, 4, 1, exif_ifd}}, Ifd({{0x8827, 3, 1, 65535}}));
  EXPECT_EQ(ParseExifTiff(only).iso.value_or(0), 65535);
}

TEST(ExifIsoTest, TheWriterWritesHighIsoAsCamerasDo) {
  for (double iso : {100.0, 65535.0, 102400.0, 409600.0}) {
    ExifInfo info;
    info.iso = iso;
    ASSERT_OK_AND_ASSIGN(const std::string jpeg,
                         EmbedExif(Encoded(".jpg"), EncodeExifTiff(info)));
    EXPECT_EQ(ParseExifFromFile(jpeg).iso.value_or(0), iso) << iso;
  }
  // ISOSpeedRatings itself saturates at 65535 (a SHORT) instead of
  // wrapping: a reader that knows only 0x8827 sees 65535.
  ExifInfo high;
  high.iso = 102400;
  const std::string tiff = EncodeExifTiff(high);
  const size_t entry = tiff.find(Le16(0x8827) + Le16(3) + Le32(1));
  ASSERT_NE(entry, std::string::npos);
  EXPECT_EQ(tiff.substr(entry + 8, 2), Le16(65535));
}

// Offsets, counts and IFD chains chosen by an attacker: every read stays
// within the block and the walk ends.
TEST(ExifHostileTest, OffsetsAndCountsOutsideTheBlockAreIgnored) {
  const std::vector<RawEntry> cases[] = {
      // Value offsets past the end, and at the very end.
      {{0x829A, 5, 1, 0xFFFFFFF0}, {0x010F, 2, 100, 0xFFFFFFFF}},
      // count x 8 overflows 32 bits (and 64-bit counts of SHORTs).
      {{0x829A, 5, 0x20000001, 26}, {0x8827, 3, 0xFFFFFFFF, 26}},
      // Unknown types and a zero count.
      {{0x829A, 99, 1, 26}, {0x8827, 3, 0, 400}},
      // The Exif IFD pointer at IFD0 itself, and past the end.
      {{0x8769, 4, 1, 8}},
      {{0x8769, 4, 1, 0xFFFFFFFF}},
  };
  for (const auto& entries : cases) {
    const ExifInfo info = ParseExifTiff(Tiff(entries));
    EXPECT_FALSE(info.exposure_s.has_value());
    EXPECT_FALSE(info.iso.has_value());
    EXPECT_EQ(info.camera, "");
  }
  // An IFD that claims 65535 entries in a block of 30 bytes.
  std::string many = "II" + Le16(42) + Le32(8) + Le16(65535) + Le16(0x8827) +
                     Le16(3) + Le32(1) + Le32(800);
  EXPECT_EQ(ParseExifTiff(many).iso.value_or(0), 800);
  many.resize(many.size() - 1);
  EXPECT_FALSE(ParseExifTiff(many).iso.has_value());
}

// Before the fix, IFD0 with 1000 Exif pointers to itself was read
// 1000^3 times (recursion to depth 2); now IFD0 and one Exif IFD are read.
TEST(ExifHostileTest, ACycleOfIfdsIsReadOnce) {
  std::vector<RawEntry> entries(999, RawEntry{0x8769, 4, 1, 8});
  entries.push_back({0x8827, 3, 1, 250});
  const ExifInfo info = ParseExifTiff(Tiff(entries));
  EXPECT_EQ(info.iso.value_or(0), 250);
  // IFD0 -> Exif IFD -> IFD0: the Exif IFD's own pointer is not followed.
  const uint32_t exif_ifd = AfterIfd0(2);
  const std::string loop =
      Tiff({{0x0110, 2, 4, Le32ValueOf("cam")}, {0x8769, 4, 1, exif_ifd}},
           Ifd({{0x8769, 4, 1, 8}, {0x8827, 3, 1, 640}}));
  const ExifInfo looped = ParseExifTiff(loop);
  EXPECT_EQ(looped.iso.value_or(0), 640);
  EXPECT_EQ(looped.camera, "cam");
}

TEST(ExifHostileTest, StringsAreBounded) {
  const std::string make(100000, 'M');
  const std::string tiff = Tiff({{0x010F, 2, 100000, AfterIfd0(1)}}, make);
  EXPECT_EQ(ParseExifTiff(tiff).camera, std::string(255, 'M'));
  // A string stops at its first NUL.
  const std::string nul =
      Tiff({{0x0110, 2, 8, AfterIfd0(1)}}, std::string("TG-4\0xyz", 8));
  EXPECT_EQ(ParseExifTiff(nul).camera, "TG-4");
}

// What LibRaw reports of a RAW file that is not a TIFF (CR3, RAF, ...) goes
// through PositiveFinite: an infinite shutter, ISO or aperture is unknown,
// as 0, negatives and NaN are.
TEST(ExifHostileTest, OnlyFinitePositiveNumbersAreKept) {
  EXPECT_EQ(PositiveFinite(0.004), 0.004);
  EXPECT_EQ(PositiveFinite(1e-300), 1e-300);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (const double v : {0.0, -0.0, -1.0, kInf, -kInf,
                         std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_EQ(PositiveFinite(v), std::nullopt) << v;
  }
  EXPECT_EQ(PositiveFinite(std::nullopt), std::nullopt);
  // LibRaw's fields are float.
  EXPECT_EQ(PositiveFinite(std::numeric_limits<float>::infinity()),
            std::nullopt);
}

TEST(ExifHostileTest, ContainerLengthsOutsideTheFileAreIgnored) {
  const std::string block = EncodeExifTiff(Sample());
  // JPEG: an APP1 segment whose length runs past the end, one shorter than
  // its own length field, and a segment cut off at every byte.
  const std::string app1 = "\xFF\xD8\xFF\xE1";
  for (const std::string& length :
       {std::string("\xFF\xFF"), std::string("\x00\x01", 2)}) {
    EXPECT_FALSE(
        ParseExifFromFile(app1 + length + "Exif" + std::string(2, '\0') + block)
            .iso.has_value());
  }
  ASSERT_OK_AND_ASSIGN(const std::string jpeg,
                       EmbedExif(Encoded(".jpg"), block));
  ASSERT_OK_AND_ASSIGN(const std::string png,
                       EmbedExif(Encoded(".png"), block));
  for (const std::string& file : {jpeg, png}) {
    for (size_t n = 0; n < 200; ++n) {
      const ExifInfo info = ParseExifFromFile(file.substr(0, n));
      if (info.iso.has_value()) {
        EXPECT_EQ(*info.iso, 400) << n;
      }
    }
  }
  // PNG: chunk lengths of 2^31 and 2^32 - 1 (PNG's own limit is 2^31 - 1).
  for (const uint32_t length : {0x80000000u, 0xFFFFFFFFu}) {
    std::string hostile = png;
    const size_t exif_chunk = hostile.find("eXIf") - 4;
    for (int b = 0; b < 4; ++b) {
      hostile[exif_chunk + b] = static_cast<char>(length >> (24 - 8 * b));
    }
    EXPECT_FALSE(ParseExifFromFile(hostile).iso.has_value()) << length;
  }
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
