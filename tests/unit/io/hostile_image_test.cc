// SPDX-License-Identifier: GPL-3.0-or-later
//
// Image files that declare more than they hold, or more than any image may
// be (issue 34): each is refused with INVALID_ARGUMENT naming the field, its
// value and the limit before anything of that size is allocated. The
// hostile files are tiny and built here, from valid ones where the format
// needs it. The suite runs with OpenCV's default image limits.
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfCompression.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfTileDescription.h>
#include <OpenEXR/ImfTiledOutputFile.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::testing::AllOf;
using ::testing::HasSubstr;

constexpr absl::StatusCode kInvalid = absl::StatusCode::kInvalidArgument;

std::string Range(int64_t min, int64_t max) {
  return absl::StrCat(" is outside [", min, ", ", max, "]");
}
int64_t MaxWidth() { return DecodedImageLimits().max_width; }
int64_t MaxHeight() { return DecodedImageLimits().max_height; }
int64_t MaxPixels() { return DecodedImageLimits().max_pixels; }

std::string Le32(uint32_t v) {
  return {static_cast<char>(v), static_cast<char>(v >> 8),
          static_cast<char>(v >> 16), static_cast<char>(v >> 24)};
}

// --- PFM --------------------------------------------------------------------

// The review's file: 59 bytes that declare 2^31 - 1 x 2^31 - 1 pixels.
// Before the fix the size check wrapped and the copy ran off the heap.
TEST(HostilePfmTest, TheReviewsFiftyNineByteFileIsRefused) {
  const std::string hostile =
      "PF\n2147483647 2147483647\n-1\n" + std::string(31, '\x7f');
  ASSERT_EQ(hostile.size(), 59u);
  const std::string why = "PFM width: 2147483647" + Range(1, MaxWidth());
  EXPECT_THAT(ParsePfm(hostile), StatusIs(kInvalid, HasSubstr(why)));
  TempDir dir;
  std::ofstream(dir / "hostile.pfm", std::ios::binary) << hostile;
  const std::string path = (dir / "hostile.pfm").string();
  EXPECT_THAT(ReadPfm(dir / "hostile.pfm"),
              StatusIs(kInvalid, HasSubstr(path + ": " + why)));
  EXPECT_THAT(DecodeImageFile(dir / "hostile.pfm"),
              StatusIs(kInvalid, HasSubstr(path + ": " + why)));
  EXPECT_THAT(DecodeImageBytes(hostile, ".PFM"),
              StatusIs(kInvalid, HasSubstr("(in memory): " + why)));
}

TEST(HostilePfmTest, EachDeclaredSizeIsCheckedAgainstItsLimit) {
  const std::pair<std::string, std::string> cases[] = {
      {"Pf\n4 2147483647\n-1\n", "PFM height: 2147483647" + Range(1, 1 << 20)},
      {"Pf\n-4 4\n-1\n", "PFM width: -4" + Range(1, MaxWidth())},
      {"Pf\n0 4\n-1\n", "PFM width: 0" + Range(1, MaxWidth())},
      {"PF\n1048576 1048576\n-1\n",
       absl::StrCat("PFM pixels (width x height): 1048576 x 1048576 is more "
                    "than the limit of ",
                    MaxPixels())},
      {"Pf\n99999999999999999999 4\n-1\n",
       "width \"99999999999999999999\" is not a whole number"},
      {"Pf\n4 0x10\n-1\n", "height \"0x10\" is not a whole number"},
      {"Pf\n4\n", "height \"\" is not a whole number"},
  };
  ASSERT_EQ(MaxHeight(), 1 << 20);
  for (const auto& [file, why] : cases) {
    EXPECT_THAT(ParsePfm(file + std::string(64, ' ')),
                StatusIs(kInvalid, HasSubstr(why)))
        << file;
  }
}

TEST(HostilePfmTest, TheScaleMustBeFiniteAndNonZero) {
  for (const char* scale : {"0", "-0.0", "nan", "inf", "-inf", "1e999", "x"}) {
    const std::string file =
        absl::StrCat("Pf\n1 1\n", scale, "\n", std::string(4, '\0'));
    EXPECT_THAT(ParsePfm(file),
                StatusIs(kInvalid,
                         HasSubstr(absl::StrCat("scale \"", scale,
                                                "\" is not a finite, non-zero "
                                                "number"))))
        << scale;
  }
  // A negative scale is the little-endian byte order, not an error.
  float one = 1.f;
  std::string le = "Pf\n1 1\n-2.5\n";
  le.append(reinterpret_cast<const char*>(&one), 4);
  ASSERT_OK_AND_ASSIGN(const cv::Mat img, ParsePfm(le));
  EXPECT_EQ(img.at<float>(0, 0), 1.f);
}

TEST(HostilePfmTest, GarbageIsQuotedBoundedly) {
  const std::string garbage(100000, 'x');
  const absl::Status magic = ParsePfm(garbage).status();
  EXPECT_THAT(magic, StatusIs(kInvalid, HasSubstr("no PF/Pf magic")));
  EXPECT_LT(magic.message().size(), 200u);
  const absl::Status width = ParsePfm("Pf\n" + garbage + " 4\n-1\n").status();
  EXPECT_THAT(width, StatusIs(kInvalid, HasSubstr("(100000 bytes)")));
  EXPECT_LT(width.message().size(), 200u);
}

TEST(HostilePfmTest, AFileShorterThanItsPixelsIsTruncated) {
  EXPECT_THAT(ParsePfm("Pf\n4 4\n-1\n" + std::string(63, '\0')),
              StatusIs(kInvalid, HasSubstr("truncated: 63 bytes of pixels, "
                                           "the header declares 64")));
  EXPECT_THAT(
      ParsePfm("Pf\n1 1\n-1"),
      StatusIs(kInvalid, HasSubstr("the header does not end in whitespace")));
  // Every prefix of a valid file is an error, none a crash.
  TempDir dir;
  ASSERT_OK(WritePfm(dir / "v.pfm", cv::Mat(3, 2, CV_32FC3, cv::Scalar(1))));
  const std::string valid = ReadFileOrDie(dir / "v.pfm");
  for (size_t n = 0; n < valid.size(); ++n) {
    EXPECT_THAT(ParsePfm(valid.substr(0, n)), StatusIs(kInvalid)) << n;
  }
  EXPECT_OK(ParsePfm(valid));
}

// --- EXR --------------------------------------------------------------------

// Where the value of the header attribute `name` of type `type` begins; its
// 4-byte size is just before it.
size_t AttributeValue(const std::string& exr, const std::string& name,
                      const std::string& type) {
  const std::string key = name + '\0' + type + '\0';
  const size_t at = exr.find(key);
  EXPECT_NE(at, std::string::npos) << name;
  return at + key.size() + 4;
}

void PutBox(std::string& exr, int32_t min_x, int32_t min_y, int32_t max_x,
            int32_t max_y) {
  const size_t at = AttributeValue(exr, "dataWindow", "box2i");
  exr.replace(at, 16, Le32(min_x) + Le32(min_y) + Le32(max_x) + Le32(max_y));
}

std::string SmallExr() {
  TempDir dir;
  cv::Mat img(4, 5, CV_32FC3, cv::Scalar(0.25, 0.5, 1));
  EXPECT_OK(WriteExr(dir / "s.exr", img, ExrPixelType::kHalf));
  return ReadFileOrDie(dir / "s.exr");
}

// An EXR written by OpenEXR itself: `channels` half channels of zeros.
std::string ExrWith(Imf::Header header, int channels, bool tiled) {
  for (int c = 0; c < channels; ++c) {
    header.channels().insert(absl::StrCat("c", c), Imf::Channel(Imf::HALF));
  }
  Imf::StdOSStream stream;
  const Imath::Box2i dw = header.dataWindow();
  // Channels without a slice are written as zeros.
  if (tiled) {
    Imf::TiledOutputFile file(stream, header);
    file.setFrameBuffer(Imf::FrameBuffer());
    file.writeTiles(0, file.numXTiles() - 1, 0, file.numYTiles() - 1);
  } else {
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(Imf::FrameBuffer());
    file.writePixels(dw.max.y - dw.min.y + 1);
  }
  return stream.str();
}

TEST(HostileExrTest, AValidFileReadsFromMemory) {
  const std::string exr = SmallExr();
  ASSERT_OK_AND_ASSIGN(const cv::Mat img, ParseExr(exr));
  EXPECT_EQ(img.size(), cv::Size(5, 4));
  EXPECT_EQ(img.at<cv::Vec3f>(3, 4), cv::Vec3f(0.25, 0.5, 1));
  ASSERT_OK_AND_ASSIGN(const DecodedImage d, DecodeImageBytes(exr, ".exr"));
  EXPECT_TRUE(d.metadata.linear);
  EXPECT_EQ(d.pixels.size(), cv::Size(5, 4));
}

// The limits leave ordinary files alone: tiled, grey, a data window off
// the origin.
TEST(HostileExrTest, TiledFilesOffTheOriginRead) {
  Imf::Header header(Imath::Box2i({0, 0}, {39, 29}),
                     Imath::Box2i({-3, 5}, {36, 34}));
  header.channels().insert("Y", Imf::Channel(Imf::HALF));
  header.setTileDescription(Imf::TileDescription(16, 16));
  ASSERT_OK_AND_ASSIGN(const cv::Mat grey,
                       ParseExr(ExrWith(header, 0, /*tiled=*/true)));
  EXPECT_EQ(grey.type(), CV_32FC1);
  EXPECT_EQ(grey.size(), cv::Size(40, 30));
  EXPECT_EQ(cv::countNonZero(grey), 0);
}

TEST(HostileExrTest, DataWindowsBeyondTheLimitsAreRefused) {
  struct Case {
    int32_t min_x, min_y, max_x, max_y;
    std::string why;
  };
  const Case cases[] = {
      // max - min + 1 overflows an int.
      {0, 0, INT32_MAX, 3, "cannot read EXR: data window width: 2147483648"},
      {INT32_MIN, 0, INT32_MAX, 3,
       "cannot read EXR: data window width: 4294967296"},
      {0, INT32_MIN, 4, 0, "cannot read EXR: data window height: 2147483649"},
      // Negative.
      {10, 0, 0, 3, "cannot read EXR: data window width: -9"},
      // Each side within the limits, the area not.
      {0, 0, (1 << 20) - 1, (1 << 20) - 1,
       absl::StrCat(
           "cannot read EXR: data window pixels (width x height): 1048576 x "
           "1048576 is more than the limit of ",
           MaxPixels())},
  };
  for (const Case& c : cases) {
    std::string exr = SmallExr();
    PutBox(exr, c.min_x, c.min_y, c.max_x, c.max_y);
    EXPECT_THAT(ParseExr(exr), StatusIs(kInvalid, HasSubstr(c.why))) << c.why;
  }
  TempDir dir;
  std::string exr = SmallExr();
  PutBox(exr, 0, 0, INT32_MAX, 3);
  std::ofstream(dir / "wide.exr", std::ios::binary) << exr;
  EXPECT_THAT(
      ReadExr(dir / "wide.exr"),
      StatusIs(kInvalid,
               HasSubstr((dir / "wide.exr").string() +
                         ": cannot read EXR: data window width: 2147483648" +
                         Range(1, MaxWidth()))));
}

// OpenEXR allocates an attribute's declared size before reading it.
TEST(HostileExrTest, AttributesLargerThanTheFileAreRefused) {
  for (const uint32_t size : {0x7FFFFFFFu, 0xFFFFFFFFu, 1000u}) {
    std::string exr = SmallExr();
    const size_t value = AttributeValue(exr, "compression", "compression");
    exr.replace(value - 4, 4, Le32(size));
    const int64_t left = static_cast<int64_t>(exr.size() - value);
    EXPECT_THAT(
        ParseExr(exr),
        StatusIs(kInvalid,
                 HasSubstr(absl::StrCat(
                     "cannot read EXR: attribute \"compression\" size: ",
                     static_cast<int32_t>(size), Range(0, left)))))
        << size;
  }
  std::string runs_off = SmallExr().substr(0, 20);
  EXPECT_THAT(
      ParseExr(runs_off),
      StatusIs(
          kInvalid,
          HasSubstr("cannot read EXR: attribute \"channels\" is cut off")));
  EXPECT_THAT(ParseExr("not an EXR file"),
              StatusIs(kInvalid,
                       HasSubstr("cannot read EXR: no OpenEXR magic number")));
}

TEST(HostileExrTest, ChunksAndTileTablesBeyondTheLimitsAreRefused) {
  // Tiles 1 pixel wide and 2^20 high over a 2^20 x 1 window: each within
  // the limits, the row of tiles InputFile buffers not.
  Imf::Header tall(8, 1);
  tall.setTileDescription(Imf::TileDescription(1, 1));
  std::string exr = ExrWith(tall, 1, /*tiled=*/true);
  PutBox(exr, 0, 0, (1 << 20) - 1, 0);
  exr.replace(AttributeValue(exr, "tiles", "tiledesc") + 4, 4, Le32(1 << 20));
  EXPECT_THAT(
      ParseExr(exr),
      StatusIs(
          kInvalid,
          HasSubstr("cannot read EXR: row of tiles pixels (width x height): "
                    "1048576 x 1048576 is more than the limit")));
  // 1 x 1 tiles over 2000 x 2000 pixels: an offset table of 32 MB that the
  // file of a few hundred bytes cannot hold.
  exr = ExrWith(tall, 1, /*tiled=*/true);
  PutBox(exr, 0, 0, 1999, 1999);
  EXPECT_THAT(
      ParseExr(exr),
      StatusIs(kInvalid,
               HasSubstr(absl::StrCat(
                   "cannot read EXR: tile offsets (level 0 tiles x 8 bytes): "
                   "4000000 x 8 is more than the limit of ",
                   exr.size()))));
  // 256 scan lines of 2^20 pixels of 100 channels in one DWAB chunk.
  Imf::Header wide(1, 1);
  wide.compression() = Imf::DWAB_COMPRESSION;
  exr = ExrWith(wide, 100, /*tiled=*/false);
  PutBox(exr, 0, 0, (1 << 20) - 1, 0);
  EXPECT_THAT(
      ParseExr(exr),
      StatusIs(kInvalid,
               HasSubstr(absl::StrCat(
                   "cannot read EXR: scan-line block bytes (all channels): ",
                   (int64_t{1} << 28) * 100 * 4, Range(1, MaxPixels() * 16)))));
}

TEST(HostileExrTest, MultiPartAndDeepFilesAreRefused) {
  std::string exr = SmallExr();
  for (const uint32_t flag : {0x1000u, 0x800u}) {
    std::string flagged = exr;
    flagged.replace(4, 4, Le32(2 | flag));
    EXPECT_THAT(ParseExr(flagged),
                StatusIs(kInvalid, HasSubstr("cannot read EXR: multi-part and "
                                             "deep files are not supported")));
  }
}

TEST(HostileExrTest, EveryPrefixOfAValidFileIsAnError) {
  const std::string exr = SmallExr();
  for (size_t n = 0; n < exr.size(); ++n) {
    EXPECT_THAT(ParseExr(absl::string_view(exr).substr(0, n)),
                StatusIs(kInvalid))
        << n;
  }
}

// --- RGBE and the formats OpenCV decodes ------------------------------------

TEST(HostileRgbeTest, DimensionsAboveTheLimitsAreRefusedBeforeDecoding) {
  const std::string hdr =
      "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2000000 +X 8\n" +
      std::string(64, '\x01');
  EXPECT_THAT(ParseRgbe(hdr),
              StatusIs(kInvalid, HasSubstr("RGBE height: 2000000 is outside "
                                           "[1, 1048576]")));
  EXPECT_THAT(ParseRgbe("P6\n1 1\n255\n\x01\x02\x03"),
              StatusIs(kInvalid, HasSubstr("not a Radiance RGBE file: it "
                                           "starts \"P6\\n1 1")));
}

// OpenCV's RGBE decoder as the peer: on well-formed files, run-length
// encoded (width 8 .. 32767) and flat (narrower), ours gives the same
// floats exactly.
TEST(RgbeReaderTest, DecodesWhatOpenCvDecodesIdentically) {
  cv::RNG rng(7);
  for (const cv::Size size :
       {cv::Size(5, 4), cv::Size(12, 3), cv::Size(300, 7)}) {
    cv::Mat radiance(size, CV_32FC3);
    rng.fill(radiance, cv::RNG::UNIFORM, 0.0, 50.0);
    radiance(cv::Rect(0, 0, size.width, 1)).setTo(cv::Scalar(2, 2, 2));  // runs
    std::vector<uchar> encoded;
    ASSERT_TRUE(cv::imencode(".hdr", radiance, encoded));
    const cv::Mat peer =
        cv::imdecode(encoded, cv::IMREAD_ANYDEPTH | cv::IMREAD_COLOR);
    ASSERT_OK_AND_ASSIGN(
        const cv::Mat ours,
        ParseRgbe(std::string(encoded.begin(), encoded.end())));
    ASSERT_EQ(ours.type(), CV_32FC3);
    ASSERT_EQ(ours.size(), size);
    EXPECT_EQ(cv::norm(ours, peer, cv::NORM_INF), 0.0) << size;
  }
}

// Refused, each before anything of the image's size is allocated or read
// past the end: what hung or overran Debian's stb_image, and what OpenCV
// leaked a descriptor on.
TEST(RgbeReaderTest, HostileFilesAreRefusedNamingWhy) {
  std::vector<uchar> encoded;
  ASSERT_TRUE(cv::imencode(
      ".hdr", cv::Mat(3, 12, CV_32FC3, cv::Scalar(1, 2, 3)), encoded));
  const std::string good(encoded.begin(), encoded.end());
  const size_t data = good.find("+X 12\n") + 6;
  // A count of 0 (stb_image loops forever on it).
  std::string zero_run = good;
  zero_run[data + 4] = '\0';
  EXPECT_THAT(ParseRgbe(zero_run),
              StatusIs(kInvalid, HasSubstr("row 0: a run of 0 at pixel 0")));
  // A run longer than the rest of its scanline.
  std::string long_run = good;
  long_run[data + 4] = static_cast<char>(128 + 13);
  EXPECT_THAT(ParseRgbe(long_run),
              StatusIs(kInvalid, HasSubstr("a run of 13 at pixel 0 of 12")));
  // A scanline mark naming another width.
  std::string width = good;
  width[data + 3] = 11;
  EXPECT_THAT(ParseRgbe(width),
              StatusIs(kInvalid, HasSubstr("scanline of 11 pixels, not 12")));
  // A 60-byte flat file declaring 2^30 pixels (stb_image allocated 12 GiB
  // and read zeros past the end).
  EXPECT_THAT(
      ParseRgbe("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 32768 +X 32768\n" +
                std::string(16, '\x01')),
      StatusIs(kInvalid, HasSubstr("truncated: 32768 scanlines of 32768 "
                                   "pixels need at least")));
  // Every prefix that cuts into the data is refused, none read past it.
  for (size_t n = data; n < good.size(); ++n) {
    EXPECT_THAT(ParseRgbe(good.substr(0, n)),
                StatusIs(kInvalid, HasSubstr("truncated")))
        << n;
  }
  EXPECT_THAT(
      ParseRgbe("#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n"),
      StatusIs(kInvalid, HasSubstr("unsupported \"FORMAT=32-bit_rle_xyze\"")));
  EXPECT_THAT(
      ParseRgbe("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 +X 1\n1234"),
      StatusIs(kInvalid, HasSubstr("is not \"-Y H +X W\"")));
  EXPECT_THAT(ParseRgbe("#?RADIANCE\n\n-Y 1 +X 1\n1234"),
              StatusIs(kInvalid, HasSubstr("no FORMAT=32-bit_rle_rgbe")));
}

// OpenCV picks its decoder by content: RGBE or EXR bytes under a camera
// file's name must not reach OpenCV's RGBE decoder (it leaks a descriptor
// per malformed file) or its EXR decoder (which skips ParseExr's checks),
// and neither may any other format cameras do not write.
TEST(HostileOpenCvFormatTest, OnlyJpegPngAndTiffReachOpenCv) {
  std::vector<uchar> hdr, bmp, png;
  ASSERT_TRUE(
      cv::imencode(".hdr", cv::Mat(3, 12, CV_32FC3, cv::Scalar(1)), hdr));
  ASSERT_TRUE(cv::imencode(".bmp", cv::Mat(3, 3, CV_8UC3, cv::Scalar(9)), bmp));
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(3, 3, CV_8UC3, cv::Scalar(9)), png));
  for (const auto& [bytes, starts] :
       {std::pair{std::string(hdr.begin(), hdr.end()), "\"#?RADIAN\""},
        std::pair{std::string(bmp.begin(), bmp.end()), "\"BM"}}) {
    for (const char* name : {".png", ".jpg", ".tif"}) {
      EXPECT_THAT(DecodeImageBytes(bytes, name),
                  StatusIs(kInvalid, AllOf(HasSubstr("not a JPEG, PNG or TIFF "
                                                     "file: it starts "),
                                           HasSubstr(starts))))
          << name;
    }
  }
  // The same PNG decodes under any of the three names.
  for (const char* name : {".png", ".jpg", ".tif"}) {
    ASSERT_OK_AND_ASSIGN(
        const DecodedImage image,
        DecodeImageBytes(std::string(png.begin(), png.end()), name));
    EXPECT_EQ(image.pixels.size(), cv::Size(3, 3));
  }
}

int OpenDescriptors() {
  return static_cast<int>(
      std::distance(std::filesystem::directory_iterator("/proc/self/fd"),
                    std::filesystem::directory_iterator()));
}

// Found by rgbe_fuzzer: OpenCV 4.6 decoded RGBE through a temporary file
// and leaked its descriptor on every malformed header or scanline, so a
// daemon reading other labs' files ran out of descriptors. Malformed files
// now cost nothing but their error.
TEST(HostileRgbeTest, MalformedFilesLeakNoDescriptor) {
  // A run-length encoded file: rows of 12 pixels or more are RLE in RGBE.
  std::vector<uchar> encoded;
  ASSERT_TRUE(cv::imencode(
      ".hdr", cv::Mat(3, 12, CV_32FC3, cv::Scalar(1, 2, 3)), encoded));
  const std::string good(encoded.begin(), encoded.end());
  ASSERT_OK(ParseRgbe(good).status());
  const std::string malformed[] = {
      "#?RADIANCE\n\n-Y 3 +X 12\n" + std::string(40, '\0'),        // no FORMAT
      good.substr(0, good.size() - 20) + std::string(20, '\xff'),  // scanline
      good.substr(0, good.size() / 2),                             // truncated
  };
  const int before = OpenDescriptors();
  for (int i = 0; i < 50; ++i) {
    for (const std::string& bytes : malformed) {
      EXPECT_THAT(ParseRgbe(bytes),
                  StatusIs(kInvalid, HasSubstr("corrupt RGBE file")));
    }
  }
  EXPECT_EQ(OpenDescriptors(), before);
}

// A PNG chunk with its CRC.
std::string PngChunk(const std::string& type, const std::string& data) {
  const std::string body = type + data;
  const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(body.data()),
                          static_cast<uInt>(body.size()));
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  return be32(static_cast<uint32_t>(data.size())) + body +
         be32(static_cast<uint32_t>(crc));
}

TEST(HostileOpenCvFormatTest, DeclaredDimensionsAboveTheLimitsAreRefused) {
  // A PNG whose IHDR declares 10^6 x 2000 pixels (8-bit grey): each side
  // within libpng's and OpenCV's limits, the area not.
  const std::string ihdr = {
      0, 0x0F, 0x42, 0x40, 0, 0, 0x07, static_cast<char>(0xD0), 8, 0, 0, 0, 0};
  // libpng reads the header up to the first IDAT.
  const std::string png = "\x89PNG\r\n\x1a\n" + PngChunk("IHDR", ihdr) +
                          PngChunk("IDAT", "\x78\x9c") + PngChunk("IEND", "");
  EXPECT_THAT(DecodeImageBytes(png, ".png"),
              StatusIs(kInvalid, AllOf(HasSubstr("(in memory): cannot decode"),
                                       HasSubstr("CV_IO_MAX_IMAGE_PIXELS"))));
  // A JPEG whose frame header declares 65280 x 65280 pixels (each side
  // within libjpeg's and OpenCV's limits, the area 4 times OpenCV's).
  std::vector<uchar> jpg;
  ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC1, cv::Scalar(7)), jpg));
  std::string jpeg(jpg.begin(), jpg.end());
  const size_t sof = jpeg.find("\xFF\xC0");
  ASSERT_NE(sof, std::string::npos);
  jpeg.replace(sof + 5, 4, std::string("\xFF\0\xFF\0", 4));
  TempDir dir;
  std::ofstream(dir / "huge.jpg", std::ios::binary) << jpeg;
  EXPECT_THAT(DecodeImageFile(dir / "huge.jpg"),
              StatusIs(kInvalid, AllOf(HasSubstr((dir / "huge.jpg").string() +
                                                 ": cannot decode"),
                                       HasSubstr("CV_IO_MAX_IMAGE_PIXELS"))));
}

TEST(HostileOpenCvFormatTest, InMemoryDecodingMatchesTheFile) {
  cv::Mat img(3, 4, CV_16UC3);
  cv::randu(img, 0, 65536);
  std::vector<uchar> tif;
  ASSERT_TRUE(cv::imencode(".tif", img, tif));
  ASSERT_OK_AND_ASSIGN(
      const DecodedImage d,
      DecodeImageBytes(std::string(tif.begin(), tif.end()), ".TIF"));
  EXPECT_EQ(d.pixels.type(), CV_16UC3);
  EXPECT_EQ(cv::norm(d.pixels, img, cv::NORM_INF), 0.0);
  EXPECT_THAT(DecodeImageBytes("", ".png"),
              StatusIs(kInvalid, HasSubstr("(in memory): empty image file")));
  EXPECT_THAT(
      DecodeImageBytes("not an image", ".png"),
      StatusIs(kInvalid, HasSubstr("(in memory): not a JPEG, PNG or "
                                   "TIFF file: it starts \"not an i\"")));
  // A PNG signature followed by garbage reaches OpenCV, which refuses it.
  EXPECT_THAT(
      DecodeImageBytes("\x89PNG\r\n\x1a\nnot an image", ".png"),
      StatusIs(kInvalid, HasSubstr("(in memory): cannot decode (corrupt or "
                                   "unsupported format)")));
}

// --- RAW --------------------------------------------------------------------

TEST(HostileRawTest, NotARawFileIsAnErrorNamingItsSource) {
  EXPECT_THAT(
      DecodeRawBytes("definitely not a raw file"),
      StatusIs(kInvalid, HasSubstr("(in memory): cannot decode RAW (open)")));
  EXPECT_THAT(
      DecodeImageBytes("definitely not a raw file", ".NEF"),
      StatusIs(kInvalid, HasSubstr("(in memory): cannot decode RAW (open)")));
  EXPECT_THAT(
      DecodeRawBytes(""),
      StatusIs(kInvalid, HasSubstr("(in memory): cannot decode RAW (open)")));
}

}  // namespace
}  // namespace hdrstereo::io
