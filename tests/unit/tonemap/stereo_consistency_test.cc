// SPDX-License-Identifier: GPL-3.0-or-later
//
// Why the WLS (Farbman) and domain-transform (Gastal) operators match badly
// on the simulator's low-texture scenes (docs/results.md, "Tone mapping for
// matching"): each view's base layer is filtered from that view's own
// content over a large support, so at the same surface point the two views'
// bases differ, and Durand's scheme divides the display by the base
// (log Ld = l - (1 - c) B). On a wall whose only matchable signal is a few
// grey levels of shading that difference moves the cost minimum.
//
// The check, on the scene's exact (noise-free) radiance: Durand's scheme
// written out here (the same steps as tonemap.cc, checked against it), once
// as the library runs it (each view its own base) and once with the right
// view's base replaced by the left view's base warped through the true
// disparity, so the two views agree by construction. Nothing else changes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/truth.h"
#include "processing/eval/disparity_eval.h"
#include "processing/filters/domain_transform.h"
#include "processing/filters/wls_filter.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/tonemap/tonemap.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::tonemap {
namespace {

// A bundled scene at `width` (the height keeps the aspect ratio).
absl::StatusOr<sim::StereoTruth> RenderTruth(const std::string& name,
                                             int width) {
  ASSIGN_OR_RETURN(sim::Scene scene, sim::LoadScene(name));
  sim::ScaleCamera(scene, width);
  sim::SimWorld world(scene);
  return world.Truth(0, 150);
}

cv::Mat Log10Luminance(const cv::Mat& bgr, float floor) {
  cv::Mat l(bgr.size(), CV_32FC1);
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3f v = bgr.at<cv::Vec3f>(y, x);
      const float lum = 0.0722f * v[0] + 0.7152f * v[1] + 0.2126f * v[2];
      l.at<float>(y, x) = std::log10(std::max(lum, floor));
    }
  }
  return l;
}

absl::StatusOr<cv::Mat> Base(Operator op, const cv::Mat& l) {
  const Params p;
  if (op == Operator::kWls) return filters::WlsFilter(l, cv::Mat(), p.wls);
  return filters::DomainTransformFilter(l, cv::Mat(), p.domain_transform);
}

// Durand's scheme with tonemap::Params' defaults: base compressed to the
// pair's base range, detail kept, pooled percentile stretch, colour ratios
// with the saturation exponent, gamma encoding. With `shared_base` the
// right base is the left one warped through the right view's truth.
absl::StatusOr<std::pair<cv::Mat, cv::Mat>> BaseDetailPair(
    const sim::StereoTruth& t, Operator op, bool shared_base) {
  const Params p;
  const cv::Mat* rad[2] = {&t.left.radiance, &t.right.radiance};
  double max_lum = 0;
  for (const cv::Mat* r : rad) {
    cv::Mat lum;
    cv::transform(*r, lum, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
    double m = 0;
    cv::minMaxLoc(lum, nullptr, &m);
    max_lum = std::max(max_lum, m);
  }
  const float floor = static_cast<float>(max_lum * 1e-6);
  cv::Mat l[2], b[2];
  for (int v = 0; v < 2; ++v) {
    l[v] = Log10Luminance(*rad[v], floor);
    ASSIGN_OR_RETURN(b[v], Base(op, l[v]));
  }
  if (shared_base) {
    for (int y = 0; y < b[1].rows; ++y) {
      for (int x = 0; x < b[1].cols; ++x) {
        const float d = t.right.disparity.at<float>(y, x);
        if (!t.right.nonoccluded.at<uchar>(y, x) || !std::isfinite(d)) continue;
        const float xl = x + d;  // the right view's disparity points right
        const int x0 = static_cast<int>(std::floor(xl));
        if (x0 < 0 || x0 + 1 >= b[0].cols) continue;
        const float f = xl - x0;
        b[1].at<float>(y, x) =
            b[0].at<float>(y, x0) * (1 - f) + b[0].at<float>(y, x0 + 1) * f;
      }
    }
  }
  double lo0, hi0, lo1, hi1;
  cv::minMaxLoc(b[0], &lo0, &hi0);
  cv::minMaxLoc(b[1], &lo1, &hi1);
  const double top = std::max(hi0, hi1);
  const float c = static_cast<float>(std::log10(p.base_contrast) /
                                     (top - std::min(lo0, lo1)));
  cv::Mat ld[2];
  std::vector<float> pool;
  for (int v = 0; v < 2; ++v) {
    ld[v].create(l[v].size(), CV_32FC1);
    for (int y = 0; y < l[v].rows; ++y) {
      for (int x = 0; x < l[v].cols; ++x) {
        const float bb = b[v].at<float>(y, x);
        ld[v].at<float>(y, x) =
            std::pow(10.0f, c * (bb - static_cast<float>(top)) +
                                l[v].at<float>(y, x) - bb);
        if (y % 2 == 0 && x % 2 == 0) pool.push_back(ld[v].at<float>(y, x));
      }
    }
  }
  std::sort(pool.begin(), pool.end());
  const float plo = pool[static_cast<size_t>(p.clip_low * (pool.size() - 1))];
  const float phi =
      pool[static_cast<size_t>((1 - p.clip_high) * (pool.size() - 1))];
  cv::Mat out[2];
  for (int v = 0; v < 2; ++v) {
    out[v].create(l[v].size(), CV_8UC3);
    for (int y = 0; y < l[v].rows; ++y) {
      for (int x = 0; x < l[v].cols; ++x) {
        const cv::Vec3f col = rad[v]->at<cv::Vec3f>(y, x);
        const float lum = std::pow(10.0f, l[v].at<float>(y, x));
        const float d =
            std::max((ld[v].at<float>(y, x) - plo) / (phi - plo), 1e-30f);
        for (int k = 0; k < 3; ++k) {
          const float ratio = std::max(col[k] / lum, 1e-7f);
          const float o =
              std::clamp(std::pow(ratio, static_cast<float>(p.saturation)) * d,
                         0.0f, 1.0f);
          out[v].at<cv::Vec3b>(y, x)[k] = cv::saturate_cast<uchar>(
              255.0f * std::pow(o, static_cast<float>(1 / p.gamma)));
        }
      }
    }
  }
  return std::make_pair(out[0], out[1]);
}

absl::StatusOr<double> MatchBadPercent(const sim::StereoTruth& t,
                                       const std::pair<cv::Mat, cv::Mat>& p,
                                       int max_disparity) {
  stereo::StereoOptions o;
  o.max_disparity = max_disparity;
  ASSIGN_OR_RETURN(const stereo::StereoResult r,
                   stereo::ComputeDisparity(p.first, p.second, o));
  eval::EvalOptions e;
  e.gt_zero_valid = true;
  ASSIGN_OR_RETURN(const eval::DisparityEvaluation ev,
                   eval::EvaluateDisparity(r.disparity, t.left.disparity,
                                           t.left.nonoccluded, cv::Mat(), e));
  return ev.nonoccluded.bad_percent[1];
}

// At the thesis table's 320 px and at the demo's 1200 px.
class ToneMappedStereoConsistencyTest : public ::testing::TestWithParam<int> {};

TEST_P(ToneMappedStereoConsistencyTest,
       ViewsOwnBaseLayersAreWhatBreaksWlsAndGastal) {
  ASSERT_OK_AND_ASSIGN(const sim::StereoTruth t,
                       RenderTruth("lab-lamp", GetParam()));
  double max_d = 0;
  cv::minMaxLoc(t.left.disparity, nullptr, &max_d, nullptr, nullptr,
                t.left.disparity < std::numeric_limits<float>::infinity());
  const int max_disparity = static_cast<int>(std::ceil(max_d)) + 2;
  for (const Operator op : {Operator::kWls, Operator::kDomainTransform}) {
    const std::string name = OperatorName(op);
    ASSERT_OK_AND_ASSIGN(const auto library,
                         ToneMapPair(t.left.radiance, t.right.radiance, op));
    ASSERT_OK_AND_ASSIGN(const auto own, BaseDetailPair(t, op, false));
    ASSERT_OK_AND_ASSIGN(const auto shared, BaseDetailPair(t, op, true));
    // The scheme written out here is the library's, to rounding.
    cv::Mat diff;
    cv::absdiff(library.first, own.first, diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LE(worst, 2) << name;
    EXPECT_LE(cv::mean(diff)[0], 0.05) << name;

    ASSERT_OK_AND_ASSIGN(const double bad_own,
                         MatchBadPercent(t, own, max_disparity));
    ASSERT_OK_AND_ASSIGN(const double bad_shared,
                         MatchBadPercent(t, shared, max_disparity));
    RecordProperty(name + "_own_bases_bad1", std::to_string(bad_own));
    RecordProperty(name + "_shared_base_bad1", std::to_string(bad_shared));
    // Measured at 320 px: own bases 55.5 % (WLS) / 49.6 % (Gastal), shared
    // base 3.7 % / 3.7 % (Reinhard on the same radiance: 3.2 %); at 1200
    // px: own 54.1 % / 39.5 % (RMSE 19.56 / 15.98), shared 3.2 % / 3.1 %
    // (RMSE 2.19 / 1.58).
    EXPECT_LE(bad_shared, 8.0) << name;
    EXPECT_GE(bad_own - bad_shared, 25.0) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Widths, ToneMappedStereoConsistencyTest,
                         ::testing::Values(320, 1200));

}  // namespace
}  // namespace hdrstereo::tonemap
