// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/decode.h"

#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/unit/structured_light/sim_capture.h"

namespace hdrstereo::structured_light {
namespace {

using testing::SimCapture;

// Synthetic frames: the camera sees the projector 1:1 over a `size` image
// with the given brightness levels.
ViewFrames Synthetic(cv::Size size, int on, int off) {
  ViewFrames view;
  view.projector_size = size;
  ExposureFrames e;
  for (const Pattern& p : AllPatterns(size)) {
    cv::Mat image = *Render(p, size);
    cv::Mat frame(size, CV_8UC1);
    frame.setTo(on, image);
    frame.setTo(off, image == 0);
    e.frames.push_back(frame);
  }
  view.exposures.push_back(e);
  return view;
}

TEST(DecodeTest, SyntheticOneToOneDecodesEveryPixel) {
  const cv::Size size(100, 60);  // not powers of two
  absl::StatusOr<DecodedView> d = Decode(Synthetic(size, 200, 20));
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->valid_pixels, size.area());
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      ASSERT_EQ(d->column.at<int32_t>(y, x), x);
      ASSERT_EQ(d->row.at<int32_t>(y, x), y);
    }
  }
  EXPECT_TRUE(d->warnings.empty());
}

TEST(DecodeTest, SixteenBitAndColourFramesDecode) {
  const cv::Size size(64, 32);
  ViewFrames view = Synthetic(size, 200, 20);
  for (cv::Mat& f : view.exposures[0].frames) {
    cv::Mat c;
    cv::merge(std::vector<cv::Mat>(3, f), c);
    c.convertTo(f, CV_16UC3, 257.0);
  }
  absl::StatusOr<DecodedView> d = Decode(view);
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->valid_pixels, size.area());
  EXPECT_EQ(d->column.at<int32_t>(5, 40), 40);
}

TEST(DecodeTest, MissingFrameOrInverseIsAClearError) {
  ViewFrames view = Synthetic({64, 32}, 200, 20);
  ViewFrames missing_inverse = view;
  missing_inverse.exposures[0].frames[7] = cv::Mat();  // col_b03_inv
  absl::StatusOr<DecodedView> d = Decode(missing_inverse);
  ASSERT_EQ(d.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(d.status().message().find("col_b03_inv is missing"),
            std::string::npos)
      << d.status();

  ViewFrames short_view = view;
  short_view.exposures[0].frames.pop_back();
  d = Decode(short_view);
  ASSERT_EQ(d.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(d.status().message().find("expected"), std::string::npos);

  ViewFrames none = view;
  none.exposures.clear();
  EXPECT_EQ(Decode(none).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(DecodeTest, SizeOrDepthMismatchIsAClearError) {
  ViewFrames view = Synthetic({64, 32}, 200, 20);
  cv::resize(view.exposures[0].frames[4], view.exposures[0].frames[4],
             {32, 16});
  absl::StatusOr<DecodedView> d = Decode(view);
  ASSERT_EQ(d.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(d.status().message().find("col_b02 is 32x16"), std::string::npos)
      << d.status();

  ViewFrames deep = Synthetic({64, 32}, 200, 20);
  deep.exposures[0].frames[3].convertTo(deep.exposures[0].frames[3], CV_32F);
  EXPECT_EQ(Decode(deep).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(DecodeTest, NoProjectorLightGivesAllInvalidMapWithWarning) {
  // Projector off: every frame is the same ambient image.
  ViewFrames view = Synthetic({64, 32}, 90, 90);
  absl::StatusOr<DecodedView> d = Decode(view);
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->valid_pixels, 0);
  EXPECT_EQ(d->lit_pixels, 0);
  ASSERT_EQ(d->warnings.size(), 1u);
  EXPECT_NE(d->warnings[0].find("all-invalid"), std::string::npos);
}

TEST(DecodeTest, LowContrastBitIsInvalidNotGuessed) {
  ViewFrames view = Synthetic({64, 32}, 200, 20);
  // Bit 5 of the columns carries no light difference (e.g. a defocused
  // projector): the column cannot be known, so nothing is decoded.
  view.exposures[0].frames[10].setTo(100);
  view.exposures[0].frames[11].setTo(101);
  absl::StatusOr<DecodedView> d = Decode(view);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->valid_pixels, 0);
  EXPECT_EQ(d->lit_pixels, 64 * 32);
}

TEST(DecodeTest, BestExposurePerPixel) {
  // Exposure 0 is saturated on the right half (pattern and inverse both
  // 255), exposure 1 is dim everywhere but still decodable.
  const cv::Size size(64, 32);
  ViewFrames a = Synthetic(size, 255, 40);
  for (cv::Mat& f : a.exposures[0].frames) f.colRange(32, 64).setTo(255);
  ViewFrames b = Synthetic(size, 60, 10);
  a.exposures.push_back(b.exposures[0]);
  absl::StatusOr<DecodedView> d = Decode(a);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->valid_pixels, size.area());
  EXPECT_EQ(d->exposure.at<uint8_t>(3, 10), 0);
  EXPECT_EQ(d->exposure.at<uint8_t>(3, 50), 1);
  EXPECT_EQ(d->column.at<int32_t>(3, 50), 50);
}

// Against the simulator: the decoded column and row equal the analytic
// projector pixel wherever the sim says the projector lights the pixel, and
// nothing is decoded where it does not (projector shadow, lamp).
class SimDecodeTest : public ::testing::TestWithParam<const char*> {};

TEST_P(SimDecodeTest, DecodeMatchesAnalyticProjectorPixel) {
  const SimCapture& capture = testing::CachedSimCapture(GetParam());
  for (int v = 0; v < 2; ++v) {
    absl::StatusOr<DecodedView> d = Decode(capture.views[v]);
    ASSERT_TRUE(d.ok()) << d.status();
    const testing::SimViewTruth& t = capture.truth[v];
    int lit = 0, decoded = 0, exact = 0, off_by_one = 0, unlit_decoded = 0;
    int unlit = 0, strong = 0, strong_decoded = 0;
    for (int y = 0; y < t.lit.rows; ++y) {
      for (int x = 0; x < t.lit.cols; ++x) {
        const int c = d->column.at<int32_t>(y, x);
        const int r = d->row.at<int32_t>(y, x);
        if (!t.lit.at<uint8_t>(y, x)) {
          ++unlit;
          if (c >= 0) ++unlit_decoded;
          continue;
        }
        if (t.emitter.at<uint8_t>(y, x)) continue;
        ++lit;
        const bool is_strong = t.strongly_lit.at<uint8_t>(y, x) != 0;
        strong += is_strong;
        if (c < 0) continue;
        strong_decoded += is_strong;
        ++decoded;
        const int dc = std::abs(c - t.column.at<int32_t>(y, x));
        const int dr = std::abs(r - t.row.at<int32_t>(y, x));
        if (dc == 0 && dr == 0) {
          ++exact;
        } else if (dc <= 1 && dr <= 1) {
          ++off_by_one;
        }
      }
    }
    const double coverage = static_cast<double>(decoded) / lit;
    const double strong_coverage = static_cast<double>(strong_decoded) / strong;
    const double exact_rate = static_cast<double>(exact) / decoded;
    const double within_one = static_cast<double>(exact + off_by_one) / decoded;
    std::cout << GetParam() << " view " << v << ": lit " << lit << ", decoded "
              << coverage * 100 << "% (lit >= 10%: " << strong_coverage * 100
              << "% of " << strong << "), exact " << exact_rate * 100
              << "%, within 1 " << within_one * 100 << "%, unlit " << unlit
              << " decoded " << unlit_decoded << "\n";
    // Thresholds: >= 98% of the pixels the projector lights with >= 10% of
    // their radiance are decoded (all lit pixels: >= 85%, see
    // sim_capture.h), >= 99.5% exactly right, all within one projector
    // pixel, none in projector shadow. (All lit pixels on lab-lamp: 86-89 %
    // since the 5-level contrast floor, 93-94 % with the old 2-level one;
    // what is left out are pixels near the lamp where the projector adds 2-4
    // grey levels, where the 2-level floor let noise decide bits at 8x the
    // sensor's noise: decode.h, decode_coverage_test.cc.)
    EXPECT_GE(strong_coverage, 0.98);
    EXPECT_GE(coverage, 0.85);
    EXPECT_GE(exact_rate, 0.995);
    EXPECT_GE(within_one, 0.9999);
    EXPECT_EQ(unlit_decoded, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, SimDecodeTest,
                         ::testing::Values("lab-lamp", "shadowed"),
                         [](const auto& info) {
                           return std::string(info.param) == "lab-lamp"
                                      ? std::string("LabLamp")
                                      : std::string("Shadowed");
                         });

}  // namespace
}  // namespace hdrstereo::structured_light
