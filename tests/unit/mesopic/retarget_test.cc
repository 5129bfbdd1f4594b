// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/mesopic/retarget.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "opencv2/core.hpp"
#include "processing/mesopic/shin_model.h"

namespace hdrstereo::mesopic {
namespace {

cv::Mat RandomFloat(int rows, int cols, float lo, float hi, int seed) {
  cv::Mat m(rows, cols, CV_32FC3);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, lo, hi);
  return m;
}

RetargetOptions Opts(double src, double dst, Method method, bool tone,
                     bool anchor_white = true) {
  RetargetOptions o;
  o.anchor_white = anchor_white;
  o.source_cd = src;
  o.display_cd = dst;
  o.method = method;
  o.tone_curve = tone;
  return o;
}

TEST(RetargetTest, MethodNamesRoundTrip) {
  for (Method m : {Method::kNone, Method::kShin, Method::kWanatSaturation,
                   Method::kRods}) {
    auto parsed = MethodFromName(MethodName(m));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, m);
  }
  EXPECT_EQ(*MethodFromName("wanat_saturation"), Method::kWanatSaturation);
  EXPECT_EQ(*MethodFromName("SHIN"), Method::kShin);
  auto bad = MethodFromName("cao");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("cao"), std::string::npos);
}

TEST(RetargetTest, RejectsBadImagesAndOptions) {
  const RetargetOptions ok;
  auto expect_invalid = [](const absl::StatusOr<cv::Mat>& r) {
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument)
        << r.status();
  };
  expect_invalid(Retarget(cv::Mat(), ok));
  expect_invalid(Retarget(cv::Mat(4, 4, CV_8UC1, cv::Scalar(1)), ok));
  expect_invalid(Retarget(cv::Mat(4, 4, CV_8UC4, cv::Scalar(1)), ok));
  expect_invalid(Retarget(cv::Mat(4, 4, CV_16UC3, cv::Scalar(1)), ok));
  cv::Mat nan_img(4, 4, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  nan_img.at<cv::Vec3f>(2, 1)[1] = std::numeric_limits<float>::quiet_NaN();
  expect_invalid(Retarget(nan_img, ok));
  cv::Mat inf_img(4, 4, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  inf_img.at<cv::Vec3f>(0, 0)[2] = std::numeric_limits<float>::infinity();
  expect_invalid(Retarget(inf_img, ok));
  const cv::Mat img(4, 4, CV_8UC3, cv::Scalar(10, 20, 30));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (double bad : {0.0, -2.0, nan, std::numeric_limits<double>::infinity()}) {
    RetargetOptions o;
    o.display_cd = bad;
    expect_invalid(Retarget(img, o));
    o = RetargetOptions();
    o.source_cd = bad;
    expect_invalid(Retarget(img, o));
    o = RetargetOptions();
    o.saturation_kappa = bad;
    expect_invalid(Retarget(img, o));
  }
  RetargetOptions o;
  o.display_contrast = 1.0;
  expect_invalid(Retarget(img, o));
  o = RetargetOptions();
  o.source_cd = 1e12;
  expect_invalid(Retarget(img, o));
}

// Forward then inverse at the same luminance through the fast float kernel
// returns the input to 1e-4 (the threshold), at scotopic, mesopic
// and photopic levels.
TEST(RetargetTest, ShinAtSameLevelIsIdentityWithin1e4) {
  const cv::Mat in = RandomFloat(64, 97, 0.0f, 1.0f, 1);
  for (double cd : {0.002, 0.05, 0.5, 2.0, 200.0}) {
    for (bool anchor : {false, true}) {
      auto out = Retarget(in, Opts(cd, cd, Method::kShin, false, anchor));
      ASSERT_TRUE(out.ok()) << out.status();
      EXPECT_LE(cv::norm(*out, in, cv::NORM_INF), 1e-4) << cd << " cd/m^2";
    }
  }
}

// The float kernel agrees with the double-precision model where the answer
// is inside the gamut.
TEST(RetargetTest, FastKernelMatchesReferenceModel) {
  const cv::Mat in = RandomFloat(32, 32, 0.2f, 0.6f, 2);
  for (double dst : {0.05, 0.5, 2.0}) {
    auto out = Retarget(in, Opts(200.0, dst, Method::kShin, false, false));
    ASSERT_TRUE(out.ok());
    const double src_lux = LuxFromWhiteLuminance(200.0);
    const double dst_lux = LuxFromWhiteLuminance(dst);
    int compared = 0;
    for (int y = 0; y < in.rows; ++y) {
      for (int x = 0; x < in.cols; ++x) {
        const cv::Vec3f p = in.at<cv::Vec3f>(y, x);
        const Vec3 ref =
            ShinInverse(ShinForward({p[2], p[1], p[0]}, src_lux), dst_lux);
        if (ref[0] < 0 || ref[1] < 0 || ref[2] < 0 || ref[0] > 1 ||
            ref[1] > 1 || ref[2] > 1) {
          continue;
        }
        ++compared;
        const cv::Vec3f q = out->at<cv::Vec3f>(y, x);
        EXPECT_NEAR(q[2], ref[0], 1e-4);
        EXPECT_NEAR(q[1], ref[1], 1e-4);
        EXPECT_NEAR(q[0], ref[2], 1e-4);
      }
    }
    EXPECT_GT(compared, in.total() / 2);
  }
}

double MeanSaturation(const cv::Mat& bgr) {
  double sum = 0.0;
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3f p = bgr.at<cv::Vec3f>(y, x);
      const float mx = std::max({p[0], p[1], p[2]});
      const float mn = std::min({p[0], p[1], p[2]});
      sum += mx > 0 ? (mx - mn) / mx : 0.0;
    }
  }
  return sum / bgr.total();
}

TEST(RetargetTest, ShinAndWanatIncreaseSaturationForADimDisplay) {
  const cv::Mat in = RandomFloat(40, 40, 0.1f, 0.7f, 3);
  const double base = MeanSaturation(in);
  for (Method m : {Method::kShin, Method::kWanatSaturation}) {
    auto out = Retarget(in, Opts(200.0, 2.0, m, false));
    ASSERT_TRUE(out.ok());
    EXPECT_GT(MeanSaturation(*out), 1.05 * base) << MethodName(m);
  }
  auto none = Retarget(in, Opts(200.0, 2.0, Method::kNone, false));
  ASSERT_TRUE(none.ok());
  EXPECT_LE(cv::norm(*none, in, cv::NORM_INF), 1e-6);
}

// Gamut handling: random and extreme inputs, every method, tone curve on and
// off, extreme display levels: never NaN, never outside [0, 1].
TEST(RetargetTest, FuzzNeverProducesNaNOrOutOfRange) {
  cv::Mat in = RandomFloat(48, 48, -1.0f, 4.0f, 4);
  const float specials[] = {0.0f, 1e-30f, 1e-12f, 1e-6f, 1.0f,
                            1e3f, 1e12f,  3e38f,  -5.0f, 0.5f};
  cv::RNG rng(5);
  for (int y = 0; y < in.rows; ++y) {
    for (int x = 0; x < in.cols; x += 2) {
      cv::Vec3f& p = in.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) p[c] = specials[rng.uniform(0, 10)];
    }
  }
  in.at<cv::Vec3f>(0, 1) = cv::Vec3f(0, 0, 1e30f);   // saturated red
  in.at<cv::Vec3f>(0, 3) = cv::Vec3f(1, 0, 0);       // saturated blue
  in.at<cv::Vec3f>(0, 5) = cv::Vec3f::all(3.4e38f);  // FLT_MAX-ish white
  in.at<cv::Vec3f>(4, 4) = cv::Vec3f::all(3.4e38f);  // in the tone sample
  const cv::Mat black(8, 8, CV_32FC3, cv::Scalar::all(0));
  const cv::Mat tiny(8, 8, CV_32FC3, cv::Scalar::all(1e-20));
  cv::Mat in8(48, 48, CV_8UC3);
  rng.fill(in8, cv::RNG::UNIFORM, 0, 256);
  in8.at<cv::Vec3b>(0, 0) = cv::Vec3b(255, 0, 0);
  for (Method m : {Method::kNone, Method::kShin, Method::kWanatSaturation,
                   Method::kRods}) {
    for (bool tone : {false, true}) {
      for (double dst : {1e-4, 0.05, 2.0, 300.0, 1e5, 1e9}) {
        for (const cv::Mat& img : {in, black, tiny}) {
          for (double src : {200.0, 1e-3, 1e9}) {
            auto out = Retarget(img, Opts(src, dst, m, tone));
            ASSERT_TRUE(out.ok()) << out.status();
            ASSERT_EQ(out->type(), CV_32FC3);
            ASSERT_EQ(out->size(), img.size());
            for (int y = 0; y < out->rows; ++y) {
              const float* p = out->ptr<float>(y);
              for (int i = 0; i < out->cols * 3; ++i) {
                ASSERT_TRUE(p[i] >= 0.0f && p[i] <= 1.0f)
                    << MethodName(m) << " tone " << tone << " dst " << dst
                    << " src " << src << " value " << p[i];
              }
            }
          }
        }
        auto out8 = Retarget(in8, Opts(200.0, dst, m, tone));
        ASSERT_TRUE(out8.ok());
        ASSERT_EQ(out8->type(), CV_8UC3);
      }
    }
  }
}

TEST(RetargetTest, RetargetIntoReusesTheBufferAndMatchesRetarget) {
  const cv::Mat in = RandomFloat(30, 40, 0.0f, 1.0f, 9);
  const RetargetOptions o = Opts(200.0, 2.0, Method::kShin, true);
  cv::Mat out(30, 40, CV_32FC3);
  const uchar* buffer = out.data;
  ASSERT_TRUE(RetargetInto(in, o, &out).ok());
  EXPECT_EQ(out.data, buffer);
  auto ref = Retarget(in, o);
  ASSERT_TRUE(ref.ok());
  EXPECT_EQ(cv::norm(out, *ref, cv::NORM_INF), 0.0);
  EXPECT_EQ(RetargetInto(in, o, nullptr).code(),
            absl::StatusCode::kInvalidArgument);
  cv::Mat alias = in;
  EXPECT_EQ(RetargetInto(in, o, &alias).code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(RetargetTest, EightBitPassThroughAndToneCurveMonotone) {
  cv::Mat ramp(1, 256, CV_8UC3);
  for (int x = 0; x < 256; ++x) ramp.at<cv::Vec3b>(0, x) = cv::Vec3b::all(x);
  auto same = Retarget(ramp, Opts(2.0, 2.0, Method::kNone, false));
  ASSERT_TRUE(same.ok());
  EXPECT_LE(cv::norm(*same, ramp, cv::NORM_INF), 1.0);
  auto toned = Retarget(ramp, Opts(200.0, 2.0, Method::kShin, true));
  ASSERT_TRUE(toned.ok());
  for (int x = 1; x < 256; ++x) {
    const cv::Vec3b a = toned->at<cv::Vec3b>(0, x - 1);
    const cv::Vec3b b = toned->at<cv::Vec3b>(0, x);
    EXPECT_GE(b[1], a[1]) << x;
    // Greys stay (nearly) grey with the white anchored (2 code values).
    EXPECT_LE(std::abs(int(b[0]) - int(b[2])), 2) << x;
    EXPECT_LE(std::abs(int(b[1]) - int(b[2])), 2) << x;
  }
  EXPECT_EQ(toned->at<cv::Vec3b>(0, 255)[1], 255);
  EXPECT_EQ(toned->at<cv::Vec3b>(0, 255)[0], 255);
  EXPECT_EQ(toned->at<cv::Vec3b>(0, 255)[2], 255);
}

// Without anchoring, Eqs. 6.2-6.5 as printed tint mid-grey at 2 cd/m^2
// (red about 6% low); with anchoring the tint is below 1.5%.
TEST(RetargetTest, WhiteAnchoringKeepsNeutralsNeutral) {
  const cv::Mat grey(4, 4, CV_32FC3, cv::Scalar::all(0.5));
  auto raw = Retarget(grey, Opts(200.0, 2.0, Method::kShin, false, false));
  auto anchored = Retarget(grey, Opts(200.0, 2.0, Method::kShin, false));
  ASSERT_TRUE(raw.ok() && anchored.ok());
  const cv::Vec3f r = raw->at<cv::Vec3f>(1, 1);
  const cv::Vec3f a = anchored->at<cv::Vec3f>(1, 1);
  EXPECT_GT(r[0] - r[2], 0.02f);  // B - R
  EXPECT_LT(std::abs(a[0] - a[2]) / a[1], 0.015f);
  EXPECT_LT(std::abs(a[1] - a[2]) / a[1], 0.015f);
  // The rod model is linear: anchored, greys stay exactly grey.
  auto rods = Retarget(grey, Opts(200.0, 2.0, Method::kRods, false));
  ASSERT_TRUE(rods.ok());
  const cv::Vec3f g = rods->at<cv::Vec3f>(1, 1);
  EXPECT_NEAR(g[0], 0.5f, 1e-5);
  EXPECT_NEAR(g[1], 0.5f, 1e-5);
  EXPECT_NEAR(g[2], 0.5f, 1e-5);
}

}  // namespace
}  // namespace hdrstereo::mesopic
