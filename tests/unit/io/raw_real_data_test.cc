// SPDX-License-Identifier: GPL-3.0-or-later
//
// A real camera RAW frame (../shared/data/raw-dng-canon550d: a Canon EOS
// 550D frame written as DNG by Magic Lantern; 14-bit RGGB, black 2056,
// white 15000, ActiveArea (26, 152, 1182, 1886)) through LibRaw. The truth
// is the file's own bit stream, unpacked here: one uncompressed strip at
// byte 1536 of 1888 x 1182 14-bit values, MSB first, no row padding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "processing/hdr/stack.h"
#include "processing/io/image.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::io {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr int kSensorWidth = 1888, kSensorHeight = 1182;
constexpr size_t kStripOffset = 1536;
constexpr int kBlack = 2056, kWhite = 15000;
const cv::Rect kActive(152, 26, 1886 - 152, 1182 - 26);  // x, y, w, h

fs::path Dng() {
  return fs::path(HDRSTEREO_SHARED_DIR) / "data" / "raw-dng-canon550d" /
         "colorchart.dng";
}

// The sensor values, unpacked from the file's bytes.
cv::Mat Unpack(const std::string& bytes) {
  cv::Mat raw(kSensorHeight, kSensorWidth, CV_16UC1);
  size_t bit = kStripOffset * 8;
  for (int y = 0; y < kSensorHeight; ++y) {
    uint16_t* row = raw.ptr<uint16_t>(y);
    for (int x = 0; x < kSensorWidth; ++x, bit += 14) {
      uint32_t v = 0;
      for (int k = 0; k < 14; ++k) {
        const size_t b = bit + k;
        v = (v << 1) |
            ((static_cast<uint8_t>(bytes[b / 8]) >> (7 - b % 8)) & 1u);
      }
      row[x] = static_cast<uint16_t>(v);
    }
  }
  return raw;
}

class RawRealDataTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(Dng())) {
      GTEST_SKIP() << Dng() << " is absent (no ../shared/data)";
    }
  }
};

TEST_F(RawRealDataTest, LibRawUsesTheDngLevelsAndActiveArea) {
  ASSERT_OK_AND_ASSIGN(DecodedImage image, DecodeImageFile(Dng()));
  ASSERT_TRUE(image.metadata.raw.has_value());
  const RawLevels& raw = *image.metadata.raw;
  EXPECT_EQ(raw.black, kBlack);
  EXPECT_EQ(raw.white, kWhite);
  EXPECT_EQ(raw.sensor_size, cv::Size(kSensorWidth, kSensorHeight));
  EXPECT_EQ(raw.active_area, kActive);
  EXPECT_EQ(raw.cfa_pattern, "RGGB");
  EXPECT_EQ(image.pixels.type(), CV_16UC3);
  EXPECT_EQ(image.pixels.size(), kActive.size());
  EXPECT_TRUE(image.metadata.linear);
  EXPECT_NE(image.metadata.camera.find("Canon"), std::string::npos);
  // Magic Lantern wrote 0 for the exposure fields: no exposure is invented.
  EXPECT_FALSE(image.metadata.exposure_s.has_value());
}

// Linear: over blocks of the active area, each decoded channel is a
// linear function of the file's own (value - black) / (white - black) of
// the block's R, G and B sites, through zero (black subtracted, no gamma,
// no offset), and the fit is best with the blocks placed at the active
// area's origin (the crop is where the DNG says).
TEST_F(RawRealDataTest, DecodesLinearlyFromTheFilesOwnBits) {
  ASSERT_OK_AND_ASSIGN(std::string bytes, ReadFileBytes(Dng()));
  ASSERT_GE(bytes.size(),
            kStripOffset + size_t{kSensorWidth} * kSensorHeight * 14 / 8);
  const cv::Mat sensor = Unpack(bytes);
  // The masked border left of the active area reads about the black level.
  const double border = cv::mean(sensor(cv::Rect(0, 26, 140, 1156)))[0];
  EXPECT_NEAR(border, kBlack, 20);
  ASSERT_OK_AND_ASSIGN(DecodedImage image, DecodeImageFile(Dng()));

  // Blocks of 16x16, at least 2 % of full scale above black in every
  // colour (about 10x the sensor noise, so that the clipping of noise at
  // black does not bias the fit).
  constexpr int kBlock = 16;
  constexpr double kMinSignal = 0.02;
  // Least squares of out_c = a . (R, G, B) + b over blocks, for blocks
  // shifted by (dx, dy) sensor pixels against the decoded image.
  auto fit = [&](int dx, int dy, double* worst_r2, double* worst_offset) {
    std::vector<cv::Vec4d> x;  // R, G, B, 1
    std::vector<cv::Vec3d> out;
    for (int by = 2; by + kBlock + 2 < kActive.height; by += kBlock) {
      for (int bx = 2; bx + kBlock + 2 < kActive.width; bx += kBlock) {
        double sum[3] = {0, 0, 0}, n[3] = {0, 0, 0};
        for (int y = by; y < by + kBlock; ++y) {
          for (int x0 = bx; x0 < bx + kBlock; ++x0) {
            // RGGB at the active area's even rows and columns.
            const int c = (y % 2 == 0 && x0 % 2 == 0)   ? 0
                          : (y % 2 == 1 && x0 % 2 == 1) ? 2
                                                        : 1;
            sum[c] +=
                (sensor.at<uint16_t>(kActive.y + y + dy, kActive.x + x0 + dx) -
                 kBlack) /
                double(kWhite - kBlack);
            n[c] += 1;
          }
        }
        const cv::Vec4d v(sum[0] / n[0], sum[1] / n[1], sum[2] / n[2], 1.0);
        if (std::min({v[0], v[1], v[2]}) < kMinSignal) continue;
        // Blocks where the colour conversion clipped a value at 0 or full
        // scale are not linear by construction.
        const cv::Mat block = image.pixels(cv::Rect(bx, by, kBlock, kBlock));
        double lo = 0, hi = 0;
        cv::minMaxLoc(block.reshape(1), &lo, &hi);
        if (lo <= 0 || hi >= 65535) continue;
        x.push_back(v);
        const cv::Scalar m = cv::mean(block);
        out.push_back({m[2], m[1], m[0]});  // BGR -> RGB
      }
    }
    cv::Mat a(static_cast<int>(x.size()), 4, CV_64F, x.data());
    *worst_r2 = 1;
    *worst_offset = 0;
    for (int c = 0; c < 3; ++c) {
      cv::Mat b(static_cast<int>(out.size()), 1, CV_64F);
      for (size_t i = 0; i < out.size(); ++i) b.at<double>(i) = out[i][c];
      cv::Mat coef;
      cv::solve(a, b, coef, cv::DECOMP_SVD);
      const cv::Mat residual = a * coef - b;
      cv::Scalar mean, sd;
      cv::meanStdDev(b, mean, sd);
      const double r2 =
          1 - cv::norm(residual, cv::NORM_L2SQR) / (sd[0] * sd[0] * b.rows);
      *worst_r2 = std::min(*worst_r2, r2);
      *worst_offset =
          std::max(*worst_offset, std::abs(coef.at<double>(3)) / 65535.0);
    }
  };
  double r2 = 0, offset = 0;
  fit(0, 0, &r2, &offset);
  std::cout << absl::StrFormat(
      "%dx%d blocks: worst R^2 %.5f, worst offset %.5f of full scale\n", kBlock,
      kBlock, r2, offset);
  // Measured on this frame: R^2 0.9990, offset 0.0003 (the red channel of
  // the sRGB conversion is the least linear). A black level 8 DN off would
  // add the red row's gains x 8 / 12944, an offset of about 0.003; a gamma
  // would bend the fit far below R^2 0.998.
  EXPECT_GE(r2, 0.998);
  EXPECT_LE(offset, 0.001);
  for (auto [dx, dy] :
       {std::pair{2, 0}, std::pair{-2, 0}, std::pair{0, 2}, std::pair{0, -2}}) {
    double r2_shifted = 0, offset_shifted = 0;
    fit(dx, dy, &r2_shifted, &offset_shifted);
    EXPECT_LT(r2_shifted, r2) << "shifted by " << dx << ", " << dy;
  }
}

TEST_F(RawRealDataTest, AStackOfFramesWithoutExposureSaysWhatIsMissing) {
  ::hdrstereo::testing::TempDir dir;
  fs::create_symlink(Dng(), dir / "a.dng");
  fs::create_symlink(Dng(), dir / "b.dng");
  EXPECT_THAT(hdr::LoadStack(dir.path()),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("missing exposure time for")));
  EXPECT_THAT(hdr::LoadStack(dir.path()),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("no exposures.txt in")));
}

}  // namespace
}  // namespace hdrstereo::io
