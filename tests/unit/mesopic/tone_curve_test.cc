// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/mesopic/tone_curve.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace hdrstereo::mesopic {
namespace {

std::vector<float> LogUniform(double lo, double hi, int n) {
  std::vector<float> v;
  for (int i = 0; i < n; ++i) {
    v.push_back(static_cast<float>(
        std::pow(10.0, std::log10(lo) + (std::log10(hi / lo)) * i / (n - 1))));
  }
  return v;
}

double LogSlope(const ToneCurve& c, double cd) {
  const double h = 1.01;
  return std::log10(c.Map(cd * h) / c.Map(cd)) / std::log10(h);
}

TEST(ToneCurveTest, ThresholdRisesInTheDark) {
  EXPECT_GT(ContrastThreshold(0.01), ContrastThreshold(1.0));
  EXPECT_GT(ContrastThreshold(1.0), ContrastThreshold(100.0));
  EXPECT_NEAR(ContrastThreshold(100.0), 0.011, 1e-12);
}

TEST(ToneCurveTest, MonotoneAnchoredAndWithinDisplayRange) {
  const auto samples = LogUniform(0.2, 200.0, 5000);
  const double black = 2.0 / 1000.0;
  const ToneCurve c = ToneCurve::Build(samples, 200.0, 2.0, black);
  EXPECT_NEAR(c.Map(200.0), 2.0, 1e-9);
  double prev = 0.0;
  for (double cd = 1e-4; cd <= 200.0; cd *= 1.05) {
    const double t = c.Map(cd);
    EXPECT_GE(t, prev);
    EXPECT_GE(t, black * (1 - 1e-9));
    EXPECT_LE(t, 2.0 * (1 + 1e-9));
    prev = t;
  }
  EXPECT_EQ(c.Map(0.0), 0.0);
  EXPECT_EQ(c.Map(-1.0), 0.0);
}

// When the display has room, the curve never reduces contrast and boosts it
// most in the dark, where the dim display loses most sensitivity.
TEST(ToneCurveTest, BoostsContrastMostInTheDarkWhenRangeAllows) {
  const auto samples = LogUniform(2.0, 200.0, 5000);
  const ToneCurve c = ToneCurve::Build(samples, 200.0, 2.0, 2.0 / 1e5);
  for (double cd = 2.5; cd < 190.0; cd *= 1.3) {
    EXPECT_GE(LogSlope(c, cd), 1.0 - 1e-6) << cd;
  }
  EXPECT_GT(LogSlope(c, 3.0), LogSlope(c, 150.0) + 0.1);
}

// A source range wider than the display compresses into the display range.
TEST(ToneCurveTest, CompressesToFitTheDisplay) {
  const auto samples = LogUniform(0.002, 200.0, 5000);
  const ToneCurve c = ToneCurve::Build(samples, 200.0, 2.0, 2.0 / 100.0);
  EXPECT_NEAR(c.Map(0.002), 0.02, 0.02 * 1e-3);
  EXPECT_NEAR(c.Map(200.0), 2.0, 1e-9);
}

TEST(ToneCurveTest, DegenerateInputsGiveAFiniteCurve) {
  for (const std::vector<float>& s :
       {std::vector<float>{}, std::vector<float>{0.0f, -1.0f},
        std::vector<float>{5.0f, 5.0f}}) {
    const ToneCurve c = ToneCurve::Build(s, 5.0, 2.0, 0.002);
    for (double cd : {1e-9, 0.5, 5.0, 1e9}) {
      const double t = c.Map(cd);
      EXPECT_TRUE(std::isfinite(t));
      EXPECT_LE(t, 2.0 + 1e-9);
    }
  }
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<float> weird = {std::numeric_limits<float>::quiet_NaN(),
                                    std::numeric_limits<float>::infinity(),
                                    1.0f};
  for (double peak : {inf, -1.0, 0.0, 100.0}) {
    const ToneCurve c = ToneCurve::Build(weird, peak, 2.0, inf);
    for (double cd : {1e-9, 0.5, 5.0, 1e9}) {
      EXPECT_TRUE(std::isfinite(c.Map(cd)));
    }
  }
}

}  // namespace
}  // namespace hdrstereo::mesopic
