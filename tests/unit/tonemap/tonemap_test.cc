// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/tonemap/tonemap.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "tests/unit/tonemap/synthetic_scene.h"

namespace hdrstereo::tonemap {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::SyntheticScene;

constexpr int kW = 256, kH = 192;

std::string Name(const ::testing::TestParamInfo<Operator>& info) {
  std::string n = OperatorName(info.param);
  std::replace(n.begin(), n.end(), '-', '_');
  return n;
}

cv::Mat Grey(const cv::Mat& bgr8) {
  cv::Mat g;
  cv::cvtColor(bgr8, g, cv::COLOR_BGR2GRAY);
  return g;
}

// Value at fraction q of the sorted 8-bit values.
int Quantile(const cv::Mat& m8, double q) {
  std::vector<uchar> v(m8.begin<uchar>(), m8.end<uchar>());
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1))];
}

cv::Mat GreyRadiance(const std::vector<std::vector<float>>& rows) {
  cv::Mat m(static_cast<int>(rows.size()), static_cast<int>(rows[0].size()),
            CV_32FC3);
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) {
      const float v = rows[y][x];
      m.at<cv::Vec3f>(y, x) = cv::Vec3f(v, v, v);
    }
  }
  return m;
}

TEST(OperatorNamesTest, RoundTripAndAllSeven) {
  const std::vector<Operator> all = AllOperators();
  ASSERT_EQ(all.size(), 7u);
  std::set<std::string> names;
  for (Operator op : all) {
    const std::string n = OperatorName(op);
    names.insert(n);
    absl::StatusOr<Operator> back = OperatorFromName(n);
    ASSERT_TRUE(back.ok()) << n;
    EXPECT_EQ(*back, op);
  }
  EXPECT_EQ(names,
            (std::set<std::string>{"reinhard", "durand", "fattal", "drago",
                                   "guided", "domain-transform", "wls"}));
  EXPECT_THAT(OperatorFromName("Reinhard"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown tone-mapping operator 'Reinhard'")));
  EXPECT_THAT(OperatorFromName("mantiuk"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown tone-mapping operator 'mantiuk'")));
  EXPECT_THAT(OperatorFromName(""),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown tone-mapping operator ''")));
}

class EveryOperatorTest : public ::testing::TestWithParam<Operator> {};

TEST_P(EveryOperatorTest, RejectsInvalidRadiance) {
  const Operator op = GetParam();
  EXPECT_EQ(ToneMap(cv::Mat(), op).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(ToneMap(cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 1, 1)), op),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("radiance must be a 2-D CV_32FC3 linear "
                                 "radiance image, got type 16")));
  EXPECT_THAT(ToneMap(cv::Mat(8, 8, CV_32FC1, cv::Scalar(1)), op),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("radiance must be a 2-D CV_32FC3 linear "
                                 "radiance image, got type 5")));
  cv::Mat img = SyntheticScene(32, 24);
  cv::Mat nan = img.clone();
  nan.at<cv::Vec3f>(3, 4)[1] = std::numeric_limits<float>::quiet_NaN();
  absl::Status s = ToneMap(nan, op).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("NaN"), std::string::npos) << s;
  cv::Mat inf = img.clone();
  inf.at<cv::Vec3f>(0, 0)[0] = std::numeric_limits<float>::infinity();
  EXPECT_THAT(ToneMap(inf, op),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("radiance contains NaN or Inf at (0, 0)")));
  cv::Mat neg = img.clone();
  neg.at<cv::Vec3f>(5, 6)[2] = -1.0f;
  s = ToneMap(neg, op).status();
  EXPECT_NE(s.message().find("negative"), std::string::npos) << s;
  EXPECT_THAT(
      ToneMap(cv::Mat(8, 8, CV_32FC3, cv::Scalar(0, 0, 0)), op),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("radiance is zero everywhere (no luminance to map)")));
  EXPECT_THAT(ToneMapPair(img, cv::Mat(), op),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("radiance of view 1 is empty")));
  Params bad;
  bad.gamma = 0.0;
  EXPECT_THAT(ToneMap(img, op, bad),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("tone mapping: gamma is 0; it must be > 0")));
}

// The synthetic scene (1 .. 8000) must use most of the 8-bit range: the 1st
// percentile of grey <= 50, the 99.9th >= 245 (Drago lifts the darkest 1 %
// to ~44 by design).
TEST_P(EveryOperatorTest, UsesMostOfTheOutputRange) {
  absl::StatusOr<cv::Mat> out = ToneMap(SyntheticScene(kW, kH), GetParam());
  ASSERT_TRUE(out.ok()) << out.status();
  ASSERT_EQ(out->type(), CV_8UC3);
  ASSERT_EQ(out->size(), cv::Size(kW, kH));
  const cv::Mat g = Grey(*out);
  const int lo = Quantile(g, 0.01), hi = Quantile(g, 0.999);
  RecordProperty("p1", lo);
  RecordProperty("p999", hi);
  EXPECT_LE(lo, 50);
  EXPECT_GE(hi, 245);
}

// A uniformly coloured image: every operator maps its (only) luminance to
// white, so the output is the colour step alone. By hand, BGR = (1, 2, 4):
// L = 0.0722 + 1.4304 + 0.8504 = 2.353, (C / L)^0.6 = 0.599, 0.907, 1.375
// (clipped to 1), ^(1 / 2.2) * 255 = 201.9, 243.9, 255.
TEST_P(EveryOperatorTest, UniformColourHandChecked) {
  const cv::Mat img(16, 16, CV_32FC3, cv::Scalar(1, 2, 4) * 37.0);
  absl::StatusOr<cv::Mat> out = ToneMap(img, GetParam());
  ASSERT_TRUE(out.ok()) << out.status();
  for (int y = 0; y < img.rows; y += 5) {
    for (int x = 0; x < img.cols; x += 5) {
      const cv::Vec3b v = out->at<cv::Vec3b>(y, x);
      EXPECT_NEAR(v[0], 202, 1);
      EXPECT_NEAR(v[1], 244, 1);
      EXPECT_EQ(v[2], 255);
    }
  }
}

// Degenerate sizes (1x1, single rows / columns, odd sizes) are handled
// without crashing and produce an image of the input's size.
TEST_P(EveryOperatorTest, TinyImages) {
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(7, 1), cv::Size(1, 5),
                              cv::Size(3, 2), cv::Size(33, 17)}) {
    absl::StatusOr<cv::Mat> out =
        ToneMap(SyntheticScene(size.width, size.height), GetParam());
    ASSERT_TRUE(out.ok()) << size << " " << out.status();
    EXPECT_EQ(out->size(), size);
    EXPECT_EQ(out->type(), CV_8UC3);
  }
}

// Same radiance in both views gives the same output, identical to the
// single-view result.
TEST_P(EveryOperatorTest, IdenticalViewsGiveIdenticalOutput) {
  const cv::Mat img = SyntheticScene(kW / 2, kH / 2);
  absl::StatusOr<std::pair<cv::Mat, cv::Mat>> pair =
      ToneMapPair(img, img, GetParam());
  absl::StatusOr<cv::Mat> single = ToneMap(img, GetParam());
  ASSERT_TRUE(pair.ok() && single.ok());
  EXPECT_EQ(cv::norm(pair->first, pair->second, cv::NORM_INF), 0.0);
  EXPECT_LE(cv::norm(pair->first, *single, cv::NORM_INF), 1.0);
}

INSTANTIATE_TEST_SUITE_P(All, EveryOperatorTest,
                         ::testing::ValuesIn(AllOperators()), Name);

// Stereo consistency: the right view is the left shifted by d = 8 pixels
// (right(x) = left(x + d)). Differences over the overlap are measured away
// from the image borders (margin 32 px).
struct Consistency {
  double max_diff;
  double frac_within_1;
};

Consistency PairConsistency(Operator op) {
  constexpr int d = 8, margin = 32;
  const cv::Mat left = SyntheticScene(kW, kH, 0);
  const cv::Mat right = SyntheticScene(kW, kH, d);
  absl::StatusOr<std::pair<cv::Mat, cv::Mat>> out =
      ToneMapPair(left, right, op);
  EXPECT_TRUE(out.ok()) << out.status();
  if (!out.ok()) return {255, 0};
  const cv::Rect roi_r(margin, margin, kW - d - 2 * margin, kH - 2 * margin);
  const cv::Rect roi_l = roi_r + cv::Point(d, 0);
  cv::Mat diff;
  cv::absdiff(out->first(roi_l), out->second(roi_r), diff);
  diff = diff.reshape(1);
  return {cv::norm(diff, cv::NORM_INF),
          cv::countNonZero(diff <= 1) / static_cast<double>(diff.total())};
}

TEST(PairConsistencyTest, GlobalOperatorsExact) {
  for (Operator op : {Operator::kReinhard, Operator::kDrago}) {
    const Consistency c = PairConsistency(op);
    EXPECT_EQ(c.max_diff, 0.0) << OperatorName(op);
  }
}

// Local operators: >= 99.9 % of the overlap within 1 level, none off by more
// than 2 (measured: durand, guided 0; wls, fattal <= 1; domain-transform one
// pixel in ~30000 at 2 -- its recursive filter has unbounded support, so the
// columns that differ at the borders reach further than the margin).
TEST(PairConsistencyTest, LocalOperatorsWithinOneLevel) {
  for (Operator op :
       {Operator::kDurand, Operator::kGuided, Operator::kDomainTransform,
        Operator::kWls, Operator::kFattal}) {
    const Consistency c = PairConsistency(op);
    RecordProperty(OperatorName(op) + "_max", std::to_string(c.max_diff));
    RecordProperty(OperatorName(op) + "_within1",
                   std::to_string(c.frac_within_1));
    EXPECT_LE(c.max_diff, 2.0) << OperatorName(op);
    EXPECT_GE(c.frac_within_1, 0.999) << OperatorName(op);
  }
}

// Global operators are monotonic in luminance: a grey ramp 1 .. 8000.
TEST(GlobalOperatorsTest, MonotonicInLuminance) {
  std::vector<float> ramp;
  for (int x = 0; x < 512; ++x) {
    ramp.push_back(static_cast<float>(std::pow(8000.0, x / 511.0)));
  }
  const cv::Mat img = GreyRadiance({ramp, ramp});
  for (Operator op : {Operator::kReinhard, Operator::kDrago}) {
    absl::StatusOr<cv::Mat> out = ToneMap(img, op);
    ASSERT_TRUE(out.ok());
    const cv::Mat g = Grey(*out);
    for (int x = 1; x < g.cols; ++x) {
      ASSERT_GE(g.at<uchar>(0, x), g.at<uchar>(0, x - 1))
          << OperatorName(op) << " x=" << x;
    }
    EXPECT_LE(g.at<uchar>(0, 0), 40) << OperatorName(op);
    EXPECT_EQ(g.at<uchar>(0, g.cols - 1), 255) << OperatorName(op);
  }
}

// Hand-computed from the formulas for the grey luminances 1, 10, 100, 1000:
// log-average Lavg = 10^1.5 = 31.623.
//   Reinhard: Ls = 0.18 L / Lavg, white = 0.18 * 1000 / Lavg = 5.692,
//     Ld = Ls (1 + Ls / 5.692^2) / (1 + Ls) = 0.005661, 0.05395, 0.3691, 1
//     -> 255 Ld^(1/2.2) = 24.3, 67.6, 162.1, 255.
//   Drago: Lw = L / Lavg, Lwmax = 31.623, Ld = 1 / log10(Lwmax + 1) *
//     ln(Lw + 1) / ln(2 + 8 (Lw / Lwmax)^(ln 0.85 / ln 0.5))
//     = 0.01612, 0.1170, 0.4968, 1 -> 39.1, 96.2, 185.5, 255.
TEST(GlobalOperatorsTest, HandCheckedValues) {
  const cv::Mat img = GreyRadiance({{1, 10}, {100, 1000}});
  struct Case {
    Operator op;
    int expected[4];
  };
  for (const Case& c : {Case{Operator::kReinhard, {24, 68, 162, 255}},
                        Case{Operator::kDrago, {39, 96, 186, 255}}}) {
    absl::StatusOr<cv::Mat> out = ToneMap(img, c.op);
    ASSERT_TRUE(out.ok());
    for (int i = 0; i < 4; ++i) {
      const cv::Vec3b v = out->at<cv::Vec3b>(i / 2, i % 2);
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(v[ch], c.expected[i], 1) << OperatorName(c.op) << " " << i;
      }
    }
  }
  // The white point can be set: a larger one darkens the top.
  Params p;
  p.reinhard.white = 100.0;
  absl::StatusOr<cv::Mat> out = ToneMap(img, Operator::kReinhard, p);
  ASSERT_TRUE(out.ok());
  EXPECT_LT(out->at<cv::Vec3b>(1, 1)[0], 250);
}

// Three flat grey stripes of 1, 10 and 100 (96, 64, 96 px): the base layer
// is the input away from the edges, so with a base contrast of 5 the display
// luminances are 5^(-1) = 0.2, 5^(-1/2) = 0.447 and 1. The 10 % clip points
// fall inside the outer stripes, so the stretch maps 0.2 -> 0 and 1 -> 1:
// 0, 0.309, 1 -> 0, 149.5, 255. Tolerances: middle +-3 levels; the dark
// stripe <= 12 (the filters leak ~1 % across the edges, which the gamma
// amplifies to ~10 levels next to black), the bright one >= 252.
TEST(BaseDetailOperatorsTest, HandCheckedStripes) {
  std::vector<float> row;
  for (int x = 0; x < 256; ++x) {
    row.push_back(x < 96 ? 1.f : x < 160 ? 10.f : 100.f);
  }
  const cv::Mat img = GreyRadiance(std::vector<std::vector<float>>(48, row));
  Params p;
  p.clip_low = 0.1;
  p.clip_high = 0.1;
  for (Operator op : {Operator::kDurand, Operator::kGuided,
                      Operator::kDomainTransform, Operator::kWls}) {
    absl::StatusOr<cv::Mat> out = ToneMap(img, op, p);
    ASSERT_TRUE(out.ok());
    const cv::Mat g = Grey(*out);
    EXPECT_LE(g.at<uchar>(24, 8), 12) << OperatorName(op);
    EXPECT_NEAR(g.at<uchar>(24, 128), 150, 3) << OperatorName(op);
    EXPECT_GE(g.at<uchar>(24, 248), 252) << OperatorName(op);
  }
}

// A 10:1 step (30 | 300) in a band of a scene whose other rows span 1 ..
// 8000, so both sides are mid-tones. Measured on the band's middle row, with
// "plateau" values taken 40 px from the edge.
struct StepProfile {
  int jump_2px;  // g(edge + 1) - g(edge - 2)
  int plateau_difference;
  int halo_dark, halo_bright;  // px within 40 of the edge off by > 3 levels
};

StepProfile MeasureStep(Operator op) {
  std::vector<float> ramp, step;
  for (int x = 0; x < kW; ++x) {
    ramp.push_back(static_cast<float>(std::pow(8000.0, x / (kW - 1.0))));
    step.push_back(x < kW / 2 ? 30.f : 300.f);
  }
  std::vector<std::vector<float>> rows(32, ramp);
  rows.insert(rows.end(), 64, step);
  absl::StatusOr<cv::Mat> out = ToneMap(GreyRadiance(rows), op);
  EXPECT_TRUE(out.ok()) << out.status();
  if (!out.ok()) return {};
  const cv::Mat g = Grey(*out);
  const int y = 64, e = kW / 2;
  StepProfile s{};
  const int dark = g.at<uchar>(y, e - 40), bright = g.at<uchar>(y, e + 40);
  s.jump_2px = g.at<uchar>(y, e + 1) - g.at<uchar>(y, e - 2);
  s.plateau_difference = bright - dark;
  for (int x = e - 40; x < e; ++x) {
    if (std::abs(g.at<uchar>(y, x) - dark) > 3) ++s.halo_dark;
  }
  for (int x = e; x < e + 40; ++x) {
    if (std::abs(g.at<uchar>(y, x) - bright) > 3) ++s.halo_bright;
  }
  return s;
}

// Base/detail operators: the step stays a step (>= 90 % of the plateau
// difference happens within 2 px, which is >= 30 levels) and the halo is at
// most 4 px wide on either side.
TEST(BaseDetailOperatorsTest, StepEdgeHasNoWideHalo) {
  for (Operator op : {Operator::kDurand, Operator::kGuided,
                      Operator::kDomainTransform, Operator::kWls}) {
    const StepProfile s = MeasureStep(op);
    RecordProperty(
        OperatorName(op) + "_halo",
        std::to_string(s.halo_dark) + "+" + std::to_string(s.halo_bright));
    EXPECT_GE(s.plateau_difference, 30) << OperatorName(op);
    EXPECT_GE(s.jump_2px, 0.9 * s.plateau_difference) << OperatorName(op);
    EXPECT_LE(s.halo_dark, 4) << OperatorName(op);
    EXPECT_LE(s.halo_bright, 4) << OperatorName(op);
  }
}

// Fattal is not a base/detail operator: attenuating the edge's gradient
// while the rows above keep theirs leaves a non-integrable field whose
// Poisson solution bends both sides smoothly (measured ~20-27 px off by > 3
// levels). The step itself stays sharp: >= 60 % of the difference within
// 2 px (measured 33 of 50 levels).
TEST(FattalTest, StepStaysSharp) {
  const StepProfile s = MeasureStep(Operator::kFattal);
  RecordProperty("fattal_halo", std::to_string(s.halo_dark) + "+" +
                                    std::to_string(s.halo_bright));
  EXPECT_GE(s.plateau_difference, 20);
  EXPECT_GE(s.jump_2px, 0.6 * s.plateau_difference);
}

}  // namespace
}  // namespace hdrstereo::tonemap
