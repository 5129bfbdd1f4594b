// SPDX-License-Identifier: GPL-3.0-or-later
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "processing/io/exif.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/io/exif_testdata.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::TempDir;

// A wide-range float image: values from 1e-3 to 1e4, seeded.
cv::Mat RandomHdr(int rows, int cols, int channels, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> exponent(-3.f, 4.f);
  cv::Mat m(rows, cols, CV_32FC(channels));
  for (int i = 0; i < rows * cols * channels; ++i) {
    m.ptr<float>()[i] = std::pow(10.f, exponent(rng));
  }
  return m;
}

// Largest |a-b| / max(|a| per pixel), so RGBE's shared exponent is fair.
double MaxRelativeError(const cv::Mat& a, const cv::Mat& b) {
  double worst = 0;
  const int ch = a.channels();
  for (int i = 0; i < a.rows * a.cols; ++i) {
    float peak = 0;
    for (int c = 0; c < ch; ++c)
      peak = std::max(peak, std::abs(a.ptr<float>()[i * ch + c]));
    for (int c = 0; c < ch; ++c) {
      const double d =
          std::abs(a.ptr<float>()[i * ch + c] - b.ptr<float>()[i * ch + c]);
      worst = std::max(worst, d / peak);
    }
  }
  return worst;
}

int CountTempFiles(const std::filesystem::path& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().filename().string().find(".tmp-") != std::string::npos) ++n;
  }
  return n;
}

TEST(PfmTest, RoundTripsOneAndThreeChannelsExactly) {
  TempDir dir;
  for (int ch : {1, 3}) {
    cv::Mat img = RandomHdr(7, 5, ch, ch);
    const auto path = dir / ("x" + std::to_string(ch) + ".pfm");
    ASSERT_TRUE(WritePfm(path, img).ok());
    absl::StatusOr<cv::Mat> back = ReadPfm(path);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_EQ(back->type(), img.type());
    EXPECT_EQ(cv::norm(*back, img, cv::NORM_INF), 0.0);
  }
  EXPECT_EQ(CountTempFiles(dir.path()), 0);
}

TEST(PfmTest, FollowsTheMiddleburyConvention) {
  TempDir dir;
  cv::Mat img = (cv::Mat_<float>(2, 2) << 1, 2, 3, 4);  // top row 1 2
  ASSERT_TRUE(WritePfm(dir / "d.pfm", img).ok());
  const std::string bytes = ReadFileOrDie(dir / "d.pfm");
  const std::string header = "Pf\n2 2\n-1.0\n";
  ASSERT_EQ(bytes.substr(0, header.size()), header);
  ASSERT_EQ(bytes.size(), header.size() + 16);
  float first[4];
  std::memcpy(first, bytes.data() + header.size(), 16);  // little-endian host
  EXPECT_EQ(first[0], 3.f);                              // bottom row first
  EXPECT_EQ(first[1], 4.f);
  EXPECT_EQ(first[2], 1.f);
}

TEST(PfmTest, ReadsBigEndianAndColourOrder) {
  TempDir dir;
  // One pixel, RGB = (1, 2, 3), big-endian (positive scale).
  std::string data = "PF\n1 1\n1.0\n";
  for (float v : {1.f, 2.f, 3.f}) {
    uint32_t u;
    std::memcpy(&u, &v, 4);
    for (int s = 24; s >= 0; s -= 8) data.push_back(static_cast<char>(u >> s));
  }
  std::ofstream(dir / "be.pfm", std::ios::binary) << data;
  absl::StatusOr<cv::Mat> img = ReadPfm(dir / "be.pfm");
  ASSERT_TRUE(img.ok()) << img.status();
  EXPECT_EQ(img->at<cv::Vec3f>(0, 0), cv::Vec3f(3, 2, 1));  // BGR
}

TEST(PfmTest, CorruptFilesAreErrorsNamingTheFile) {
  TempDir dir;
  std::ofstream(dir / "t.pfm", std::ios::binary) << "Pf\n4 4\n-1.0\nabc";
  std::ofstream(dir / "m.pfm", std::ios::binary) << "P6\n4 4\n255\n";
  for (const char* name : {"t.pfm", "m.pfm", "none.pfm"}) {
    absl::Status s = ReadPfm(dir / name).status();
    EXPECT_THAT(s, StatusIs(std::string(name) == "none.pfm"
                                ? absl::StatusCode::kNotFound
                                : absl::StatusCode::kInvalidArgument,
                            HasSubstr(name)));
    EXPECT_NE(s.message().find(name), absl::string_view::npos) << s;
  }
}

TEST(ExrTest, RoundTripsFloatExactlyAndHalfWithinHalfPrecision) {
  TempDir dir;
  cv::Mat img = RandomHdr(9, 11, 3, 7);
  ASSERT_TRUE(WriteExr(dir / "f.exr", img, ExrPixelType::kFloat).ok());
  absl::StatusOr<cv::Mat> f = ReadExr(dir / "f.exr");
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(cv::norm(*f, img, cv::NORM_INF), 0.0);

  absl::Status hs = WriteExr(dir / "h.exr", img, ExrPixelType::kHalf);
  ASSERT_TRUE(hs.ok()) << hs;
  absl::StatusOr<cv::Mat> h = ReadExr(dir / "h.exr");
  ASSERT_TRUE(h.ok()) << h.status();
  cv::Mat rel;
  cv::divide(cv::abs(*h - img), img, rel);
  double worst = 0;
  cv::minMaxLoc(rel.reshape(1), nullptr, &worst);
  EXPECT_LE(worst, 1e-3);  // half has an 11-bit significand (4.9e-4)

  cv::Mat grey = RandomHdr(4, 6, 1, 8);
  ASSERT_TRUE(WriteExr(dir / "y.exr", grey, ExrPixelType::kFloat).ok());
  absl::StatusOr<cv::Mat> y = ReadExr(dir / "y.exr");
  ASSERT_TRUE(y.ok()) << y.status();
  EXPECT_EQ(y->channels(), 1);
  EXPECT_EQ(cv::norm(*y, grey, cv::NORM_INF), 0.0);
  EXPECT_EQ(CountTempFiles(dir.path()), 0);
}

TEST(DecodeTest, DecodesFloatFormatsAsLinear) {
  TempDir dir;
  cv::Mat img = RandomHdr(3, 4, 3, 11);
  ASSERT_TRUE(WritePfm(dir / "a.pfm", img).ok());
  ASSERT_TRUE(WriteExr(dir / "a.exr", img, ExrPixelType::kFloat).ok());
  for (const char* name : {"a.pfm", "a.exr"}) {
    absl::StatusOr<DecodedImage> d = DecodeImageFile(dir / name);
    ASSERT_TRUE(d.ok()) << d.status();
    EXPECT_TRUE(d->metadata.linear);
    EXPECT_EQ(cv::norm(d->pixels, img, cv::NORM_INF), 0.0) << name;
  }
}

TEST(ExrTest, CorruptFileIsAnErrorNamingIt) {
  TempDir dir;
  std::ofstream(dir / "bad.exr", std::ios::binary) << "v/1\x01 not really";
  absl::Status s = ReadExr(dir / "bad.exr").status();
  EXPECT_THAT(s, StatusIs(absl::StatusCode::kInvalidArgument,
                          HasSubstr("cannot read EXR")));
  EXPECT_NE(s.message().find("bad.exr"), absl::string_view::npos) << s;
}

TEST(RgbeTest, RoundTripsWithinRgbePrecision) {
  TempDir dir;
  cv::Mat img = RandomHdr(10, 12, 3, 9);
  ASSERT_TRUE(WriteRgbe(dir / "r.hdr", img).ok());
  EXPECT_EQ(ReadFileOrDie(dir / "r.hdr").substr(0, 2), "#?");
  absl::StatusOr<cv::Mat> back = ReadRgbe(dir / "r.hdr");
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->type(), CV_32FC3);
  // 8-bit mantissas with a shared exponent: error <= 1/128 of the pixel's
  // largest channel.
  EXPECT_LE(MaxRelativeError(img, *back), 1.0 / 128);
  std::ofstream(dir / "bad.hdr")
      << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4";
  absl::Status s = ReadRgbe(dir / "bad.hdr").status();
  EXPECT_THAT(s, StatusIs(absl::StatusCode::kInvalidArgument,
                          HasSubstr("corrupt RGBE file")));
  EXPECT_NE(s.message().find("bad.hdr"), absl::string_view::npos) << s;
}

TEST(PngTest, RoundTrips8And16BitExactly) {
  TempDir dir;
  cv::Mat img8(5, 7, CV_8UC3), img16(5, 7, CV_16UC1);
  cv::randu(img8, 0, 256);
  cv::randu(img16, 0, 65536);
  ASSERT_TRUE(WritePng(dir / "a.png", img8).ok());
  ASSERT_TRUE(WritePng(dir / "b.png", img16).ok());
  absl::StatusOr<DecodedImage> a = DecodeImageFile(dir / "a.png");
  absl::StatusOr<DecodedImage> b = DecodeImageFile(dir / "b.png");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->pixels.type(), CV_8UC3);
  EXPECT_EQ(b->pixels.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(a->pixels, img8, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(b->pixels, img16, cv::NORM_INF), 0.0);
  EXPECT_THAT(WritePng(dir / "f.png", cv::Mat(2, 2, CV_32F)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("PNG needs an 8- or 16-bit image")));
  absl::Status s = WritePng(dir / "no/dir/x.png", img8);
  EXPECT_NE(s.message().find("no/dir"), absl::string_view::npos) << s;
}

TEST(DecodeTest, Reads16BitTiffAndConvertsToFloat) {
  TempDir dir;
  cv::Mat img(4, 6, CV_16UC3);
  cv::randu(img, 0, 65536);
  ASSERT_TRUE(WriteImage(dir / "t.tiff", img).ok());
  absl::StatusOr<DecodedImage> d = DecodeImageFile(dir / "t.tiff");
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->pixels.type(), CV_16UC3);
  EXPECT_EQ(cv::norm(d->pixels, img, cv::NORM_INF), 0.0);
  cv::Mat f = ToFloat(d->pixels);
  EXPECT_FLOAT_EQ(f.at<cv::Vec3f>(1, 2)[1],
                  img.at<cv::Vec3w>(1, 2)[1] / 65535.f);
  EXPECT_FALSE(d->metadata.exposure_s.has_value());
}

TEST(DecodeTest, BadFilesAreErrorsNamingTheFile) {
  TempDir dir;
  cv::Mat img(16, 16, CV_8UC3, cv::Scalar(1, 2, 3));
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  std::ofstream(dir / "cut.png", std::ios::binary)
      .write(reinterpret_cast<const char*>(png.data()), 20);
  std::ofstream(dir / "empty.jpg");
  std::ofstream(dir / "junk.nef") << "definitely not a raw file";
  for (const char* name : {"cut.png", "empty.jpg", "junk.nef", "missing.tif"}) {
    absl::Status s = DecodeImageFile(dir / name).status();
    EXPECT_THAT(s, StatusIs(std::string(name) == "missing.tif"
                                ? absl::StatusCode::kNotFound
                                : absl::StatusCode::kInvalidArgument,
                            HasSubstr(name)))
        << name;
    EXPECT_NE(s.message().find(name), absl::string_view::npos) << s;
  }
}

TEST(ExifTest, ReadsExposureIsoApertureFromJpeg) {
  TempDir dir;
  cv::Mat img(8, 8, CV_8UC3, cv::Scalar(10, 20, 30));
  std::ofstream(dir / "e.jpg", std::ios::binary)
      << ::hdrstereo::testing::JpegWithExif(img, 250);
  absl::StatusOr<DecodedImage> d = DecodeImageFile(dir / "e.jpg");
  ASSERT_TRUE(d.ok()) << d.status();
  ASSERT_TRUE(d->metadata.exposure_s.has_value());
  EXPECT_DOUBLE_EQ(*d->metadata.exposure_s, 1.0 / 250);
  EXPECT_DOUBLE_EQ(d->metadata.aperture.value_or(0), 5.6);
  EXPECT_DOUBLE_EQ(d->metadata.iso.value_or(0), 200);
  EXPECT_EQ(d->metadata.camera, "Nikon");
  EXPECT_FALSE(d->metadata.linear);
}

TEST(ExifTest, TruncatedBlocksNeverCrash) {
  const std::string exif = ::hdrstereo::testing::ExifBlock();
  for (size_t n = 0; n < exif.size(); ++n) {
    ExifInfo info = ParseExifTiff(absl::string_view(exif).substr(0, n));
    if (info.exposure_s) {
      EXPECT_DOUBLE_EQ(*info.exposure_s, 1.0 / 250);
    }
  }
  EXPECT_DOUBLE_EQ(ParseExifTiff(exif).exposure_s.value_or(0), 0.004);
}

}  // namespace
}  // namespace hdrstereo::io
