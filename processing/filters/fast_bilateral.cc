// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/fast_bilateral.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/filters/mat_checks.h"

namespace hdrstereo::filters {
namespace {

struct Tap {
  int i0, i1;
  float f;  // weight of i1
};

std::vector<Tap> Taps(int full, int low, int ds) {
  std::vector<Tap> taps(full);
  for (int k = 0; k < full; ++k) {
    const float c = (k + 0.5f) / ds - 0.5f;
    const float cc = std::clamp(c, 0.0f, static_cast<float>(low - 1));
    const int i0 = std::min(static_cast<int>(cc), low - 1);
    const int i1 = std::min(i0 + 1, low - 1);
    taps[k] = {i0, i1, cc - i0};
  }
  return taps;
}

}  // namespace

absl::StatusOr<cv::Mat> FastBilateralFilter(
    const cv::Mat& src, const FastBilateralOptions& options) {
  RETURN_IF_ERROR(
      CheckImage(src, "bilateral input", /*float_only=*/false, {1}));
  if (!(options.sigma_s > 0) || !(options.sigma_r > 0) ||
      !std::isfinite(options.sigma_s) || !std::isfinite(options.sigma_r) ||
      options.downsample < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("bilateral needs sigma_s > 0, sigma_r > 0; got ",
                     options.sigma_s, ", ", options.sigma_r));
  }
  try {
    const cv::Mat in = ToFloat(src);
    double lo = 0, hi = 0;
    cv::minMaxLoc(in, &lo, &hi);
    if (hi - lo < 1e-12) return in.clone();
    const int ds =
        options.downsample > 0
            ? options.downsample
            : std::max(1, static_cast<int>(std::floor(options.sigma_s / 2.0)));
    const int segments = std::max(
        2, static_cast<int>(std::ceil((hi - lo) / options.sigma_r)) + 1);
    const double step = (hi - lo) / (segments - 1);
    const cv::Size low_size((in.cols + ds - 1) / ds, (in.rows + ds - 1) / ds);
    cv::Mat low;
    if (ds == 1) {
      low = in;
    } else {
      cv::resize(in, low, low_size, 0, 0, cv::INTER_AREA);
    }
    const double blur_sigma = options.sigma_s / ds;
    const float inv_two_sr2 =
        static_cast<float>(1.0 / (2.0 * options.sigma_r * options.sigma_r));
    std::vector<cv::Mat> j_planes(segments);
    cv::Mat g(low_size, CV_32FC1), h(low_size, CV_32FC1);
    const int n = low_size.area();
    cv::Mat low_c = low.isContinuous() ? low : low.clone();
    for (int j = 0; j < segments; ++j) {
      const float ij = static_cast<float>(lo + j * step);
      const float* pl = low_c.ptr<float>();
      float* pg = g.ptr<float>();
      float* ph = h.ptr<float>();
      for (int k = 0; k < n; ++k) {
        const float d = pl[k] - ij;
        pg[k] = -d * d * inv_two_sr2;
      }
      cv::hal::exp32f(pg, pg, n);
      for (int k = 0; k < n; ++k) ph[k] = pg[k] * pl[k];
      cv::Mat gb, hb;
      cv::GaussianBlur(g, gb, cv::Size(0, 0), blur_sigma, blur_sigma,
                       cv::BORDER_REFLECT);
      cv::GaussianBlur(h, hb, cv::Size(0, 0), blur_sigma, blur_sigma,
                       cv::BORDER_REFLECT);
      cv::Mat jp(low_size, CV_32FC1);
      const float* pgb = gb.ptr<float>();
      const float* phb = hb.ptr<float>();
      float* pj = jp.ptr<float>();
      constexpr float kTiny = 1e-12f;
      for (int k = 0; k < n; ++k) {
        pj[k] = (phb[k] + kTiny * ij) / (pgb[k] + kTiny);
      }
      j_planes[j] = jp;
    }
    const std::vector<Tap> tx = Taps(in.cols, low_size.width, ds);
    const std::vector<Tap> ty = Taps(in.rows, low_size.height, ds);
    cv::Mat out(in.size(), CV_32FC1);
    const float flo = static_cast<float>(lo);
    const float inv_step = static_cast<float>(1.0 / step);
    cv::parallel_for_(cv::Range(0, in.rows), [&](const cv::Range& r) {
      for (int y = r.start; y < r.end; ++y) {
        const Tap& t = ty[y];
        const float* src_row = in.ptr<float>(y);
        float* o = out.ptr<float>(y);
        for (int x = 0; x < in.cols; ++x) {
          const float v = (src_row[x] - flo) * inv_step;
          const int j = std::clamp(static_cast<int>(v), 0, segments - 2);
          const float fj = std::clamp(v - j, 0.0f, 1.0f);
          const Tap& s = tx[x];
          float val[2];
          for (int k = 0; k < 2; ++k) {
            const cv::Mat& p = j_planes[j + k];
            const float* r0 = p.ptr<float>(t.i0);
            const float* r1 = p.ptr<float>(t.i1);
            const float top = r0[s.i0] + s.f * (r0[s.i1] - r0[s.i0]);
            const float bot = r1[s.i0] + s.f * (r1[s.i1] - r1[s.i0]);
            val[k] = top + t.f * (bot - top);
          }
          o[x] = val[0] + fj * (val[1] - val[0]);
        }
      }
    });
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("bilateral filter: ", e.what()));
  }
}

}  // namespace hdrstereo::filters
