// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/domain_transform.h"

#include <cmath>
#include <opencv2/core/hal/hal.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/filters/mat_checks.h"

namespace hdrstereo::filters {
namespace {

// dx(y, x) = 1 + k * sum_c |g(y, x) - g(y, x - 1)| for x >= 1 (dx(y, 0)
// unused), dy(y, x) = 1 + k * sum_c |g(y, x) - g(y - 1, x)| for y >= 1.
void DomainDerivatives(const std::vector<cv::Mat>& guide, float k, cv::Mat& dx,
                       cv::Mat& dy) {
  const cv::Size sz = guide[0].size();
  dx.create(sz, CV_32FC1);
  dy.create(sz, CV_32FC1);
  dx.setTo(1.0f);
  dy.setTo(1.0f);
  for (const cv::Mat& g : guide) {
    for (int y = 0; y < sz.height; ++y) {
      const float* p = g.ptr<float>(y);
      const float* up = g.ptr<float>(y > 0 ? y - 1 : 0);
      float* ox = dx.ptr<float>(y);
      float* oy = dy.ptr<float>(y);
      for (int x = 1; x < sz.width; ++x)
        ox[x] += k * std::fabs(p[x] - p[x - 1]);
      if (y > 0) {
        for (int x = 0; x < sz.width; ++x) oy[x] += k * std::fabs(p[x] - up[x]);
      }
    }
  }
}

// w = a^d = exp(d * ln a), vectorised.
void Weights(const cv::Mat& d, float ln_a, cv::Mat& w) {
  w.create(d.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, d.rows), [&](const cv::Range& r) {
    std::vector<float> buf(d.cols);
    for (int y = r.start; y < r.end; ++y) {
      const float* pd = d.ptr<float>(y);
      for (int x = 0; x < d.cols; ++x) buf[x] = pd[x] * ln_a;
      cv::hal::exp32f(buf.data(), w.ptr<float>(y), d.cols);
    }
  });
}

void HorizontalPass(cv::Mat& img, const cv::Mat& w) {
  cv::parallel_for_(cv::Range(0, img.rows), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      float* p = img.ptr<float>(y);
      const float* a = w.ptr<float>(y);
      for (int x = 1; x < img.cols; ++x) p[x] += a[x] * (p[x - 1] - p[x]);
      for (int x = img.cols - 2; x >= 0; --x) {
        p[x] += a[x + 1] * (p[x + 1] - p[x]);
      }
    }
  });
}

void VerticalPass(cv::Mat& img, const cv::Mat& w) {
  const int stripe = 64;
  const int stripes = (img.cols + stripe - 1) / stripe;
  cv::parallel_for_(cv::Range(0, stripes), [&](const cv::Range& r) {
    const int x0 = r.start * stripe;
    const int x1 = std::min(img.cols, r.end * stripe);
    for (int y = 1; y < img.rows; ++y) {
      float* p = img.ptr<float>(y);
      const float* q = img.ptr<float>(y - 1);
      const float* a = w.ptr<float>(y);
      for (int x = x0; x < x1; ++x) p[x] += a[x] * (q[x] - p[x]);
    }
    for (int y = img.rows - 2; y >= 0; --y) {
      float* p = img.ptr<float>(y);
      const float* q = img.ptr<float>(y + 1);
      const float* a = w.ptr<float>(y + 1);
      for (int x = x0; x < x1; ++x) p[x] += a[x] * (q[x] - p[x]);
    }
  });
}

}  // namespace

absl::StatusOr<cv::Mat> DomainTransformFilter(
    const cv::Mat& src, const cv::Mat& guide,
    const DomainTransformOptions& options) {
  RETURN_IF_ERROR(
      CheckImage(src, "domain transform input", /*float_only=*/false, {}));
  const cv::Mat& g = guide.empty() ? src : guide;
  RETURN_IF_ERROR(
      CheckImage(g, "domain transform guide", /*float_only=*/false, {1, 3}));
  if (g.size() != src.size()) {
    return absl::InvalidArgumentError(
        "domain transform input and guide differ in size");
  }
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("domain transform: ", s.message()));
  }
  try {
    std::vector<cv::Mat> guide_planes;
    cv::split(ToFloat(g), guide_planes);
    cv::Mat dx, dy;
    DomainDerivatives(guide_planes,
                      static_cast<float>(options.sigma_s / options.sigma_r), dx,
                      dy);
    std::vector<cv::Mat> planes;
    cv::split(ToFloat(src), planes);
    for (cv::Mat& p : planes) p = p.clone();  // filtered in place
    const int n = options.iterations;
    cv::Mat wx, wy;
    for (int i = 0; i < n; ++i) {
      const double sigma_h = options.sigma_s * std::sqrt(3.0) *
                             std::pow(2.0, n - (i + 1)) /
                             std::sqrt(std::pow(4.0, n) - 1.0);
      const float ln_a = static_cast<float>(-std::sqrt(2.0) / sigma_h);
      Weights(dx, ln_a, wx);
      Weights(dy, ln_a, wy);
      for (cv::Mat& p : planes) {
        HorizontalPass(p, wx);
        VerticalPass(p, wy);
      }
    }
    cv::Mat out;
    cv::merge(planes, out);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("domain transform: ", e.what()));
  }
}

}  // namespace hdrstereo::filters
