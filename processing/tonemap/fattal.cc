// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/tonemap/fattal.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/tonemap/pooled_quantiles.h"

namespace hdrstereo::tonemap {
namespace {

// Gradient magnitude with central differences (one-sided at the border),
// scaled for pyramid level k (pixel spacing 2^k).
cv::Mat GradientMagnitude(const cv::Mat& h, int level) {
  const float scale = 1.0f / static_cast<float>(1 << (level + 1));
  cv::Mat g(h.size(), CV_32FC1);
  const int w = h.cols, rows = h.rows;
  for (int y = 0; y < rows; ++y) {
    const float* p = h.ptr<float>(y);
    const float* up = h.ptr<float>(std::max(y - 1, 0));
    const float* dn = h.ptr<float>(std::min(y + 1, rows - 1));
    float* o = g.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const float gx =
          (p[std::min(x + 1, w - 1)] - p[std::max(x - 1, 0)]) * scale;
      const float gy = (dn[x] - up[x]) * scale;
      o[x] = std::sqrt(gx * gx + gy * gy);
    }
  }
  return g;
}

// phi = (g / alpha)^(beta - 1), with g floored at alpha / 100.
cv::Mat Attenuation(const cv::Mat& grad, double alpha, double beta) {
  cv::Mat phi(grad.size(), CV_32FC1);
  const float floor_g = static_cast<float>(alpha / 100.0);
  const float inv_alpha = static_cast<float>(1.0 / alpha);
  const float e = static_cast<float>(beta - 1.0);
  std::vector<float> buf(grad.cols);
  for (int y = 0; y < grad.rows; ++y) {
    const float* g = grad.ptr<float>(y);
    for (int x = 0; x < grad.cols; ++x) {
      buf[x] = std::max(g[x], floor_g) * inv_alpha;
    }
    cv::hal::log32f(buf.data(), buf.data(), grad.cols);
    for (int x = 0; x < grad.cols; ++x) buf[x] *= e;
    cv::hal::exp32f(buf.data(), phi.ptr<float>(y), grad.cols);
  }
  return phi;
}

// Divides DCT coefficients by the Laplacian's eigenvalues
// 2 cos(pi u / w) - 2 + 2 cos(pi v / h) - 2 (the constant mode is set to 0).
void DivideByEigenvalues(cv::Mat& spec, int w, int h, double pi) {
  std::vector<double> cx(w);
  for (int u = 0; u < w; ++u) cx[u] = 2.0 * std::cos(pi * u / w) - 2.0;
  for (int v = 0; v < h; ++v) {
    double* s = spec.ptr<double>(v);
    const double cy = 2.0 * std::cos(pi * v / h) - 2.0;
    for (int u = 0; u < w; ++u) {
      s[u] = (u == 0 && v == 0) ? 0.0 : s[u] / (cx[u] + cy);
    }
  }
}

// Median of a - b over the pixels with lo <= a <= hi (every second pixel of
// every second row); over all pixels if none qualifies.
float MedianDifference(const cv::Mat& a, const cv::Mat& b, float lo, float hi) {
  std::vector<float> d, all;
  for (int y = 0; y < a.rows; y += 2) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    for (int x = 0; x < a.cols; x += 2) {
      all.push_back(pa[x] - pb[x]);
      if (pa[x] >= lo && pa[x] <= hi) d.push_back(pa[x] - pb[x]);
    }
  }
  std::vector<float>& v = d.empty() ? all : d;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

absl::StatusOr<cv::Mat> SolvePoissonNeumann(const cv::Mat& f) {
  if (f.empty() || f.channels() != 1 ||
      (f.depth() != CV_32F && f.depth() != CV_64F)) {
    return absl::InvalidArgumentError(
        "Poisson right-hand side must be a non-empty CV_32FC1/CV_64FC1");
  }
  try {
    const int w = f.cols, h = f.rows;
    cv::Mat rhs;
    f.convertTo(rhs, CV_64F);
    cv::Mat sol;
    if (w % 2 == 0 && h % 2 == 0) {
      // DCT-II diagonalises the Neumann 5-point Laplacian.
      cv::Mat spec;
      cv::dct(rhs, spec);
      DivideByEigenvalues(spec, w, h, std::numbers::pi);
      cv::dct(spec, sol, cv::DCT_INVERSE);
    } else {
      // cv::dct needs even sizes. The even (mirror) extension to 2w x 2h
      // turns the Neumann problem into a periodic one of the same solution,
      // diagonalised by the DFT.
      cv::Mat ext;
      cv::Mat flipped_x, flipped_y, flipped_xy;
      cv::flip(rhs, flipped_x, 1);
      cv::flip(rhs, flipped_y, 0);
      cv::flip(rhs, flipped_xy, -1);
      cv::Mat top, bottom;
      cv::hconcat(rhs, flipped_x, top);
      cv::hconcat(flipped_y, flipped_xy, bottom);
      cv::vconcat(top, bottom, ext);
      cv::Mat spec;
      cv::dft(ext, spec, cv::DFT_COMPLEX_OUTPUT);
      const int ew = 2 * w, eh = 2 * h;
      for (int v = 0; v < eh; ++v) {
        cv::Vec2d* s = spec.ptr<cv::Vec2d>(v);
        const double cy = 2.0 * std::cos(2.0 * std::numbers::pi * v / eh) - 2.0;
        for (int u = 0; u < ew; ++u) {
          const double lambda =
              cy + 2.0 * std::cos(2.0 * std::numbers::pi * u / ew) - 2.0;
          s[u] = (u == 0 && v == 0) ? cv::Vec2d(0, 0) : s[u] / lambda;
        }
      }
      cv::Mat full;
      cv::dft(spec, full,
              cv::DFT_INVERSE | cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
      sol = full(cv::Rect(0, 0, w, h));
    }
    cv::Mat out = sol.clone();
    out -= cv::mean(out)[0];
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("Poisson solve: ", e.what()));
  }
}

namespace {

// Fattal et al. at the views' own size.
absl::StatusOr<std::vector<cv::Mat>> CompressAtOwnSize(
    const std::vector<cv::Mat>& log_lum, const FattalOptions& params) {
  try {
    const size_t views = log_lum.size();
    // Gaussian pyramids and gradient magnitudes per view and level. All views
    // get the same number of levels (that of the smallest view).
    int levels = 1;
    {
      int min_side = INT32_MAX;
      for (const cv::Mat& m : log_lum) {
        min_side = std::min({min_side, m.cols, m.rows});
      }
      while (min_side / 2 >= params.min_level_size) {
        min_side = (min_side + 1) / 2;
        ++levels;
      }
    }
    std::vector<std::vector<cv::Mat>> grads(views);
    std::vector<double> sum(levels, 0.0), count(levels, 0.0);
    for (size_t v = 0; v < views; ++v) {
      cv::Mat level = log_lum[v];
      for (int k = 0; k < levels; ++k) {
        if (k > 0) {
          cv::Mat down;
          cv::pyrDown(level, down);
          level = down;
        }
        grads[v].push_back(GradientMagnitude(level, k));
        sum[k] += cv::sum(grads[v][k])[0];
        count[k] += grads[v][k].total();
      }
    }
    const auto [band_lo, band_hi] = PooledQuantiles(log_lum, 0.4, 0.6);
    std::vector<cv::Mat> out(views);
    for (size_t v = 0; v < views; ++v) {
      // Attenuation accumulated from the coarsest level down.
      cv::Mat phi;
      for (int k = levels - 1; k >= 0; --k) {
        const double alpha = params.alpha * sum[k] / std::max(count[k], 1.0);
        cv::Mat a = params.beta == 1.0 || alpha <= 0
                        ? cv::Mat(grads[v][k].size(), CV_32FC1, cv::Scalar(1))
                        : Attenuation(grads[v][k], alpha, params.beta);
        if (!phi.empty()) {
          cv::Mat up;
          cv::resize(phi, up, a.size(), 0, 0, cv::INTER_LINEAR);
          a = a.mul(up);
        }
        phi = a;
      }
      // Attenuated forward-difference gradients (Neumann: zero across the
      // border) and their divergence (backward differences).
      const cv::Mat& h = log_lum[v];
      const int w = h.cols, rows = h.rows;
      cv::Mat gx = cv::Mat::zeros(h.size(), CV_32FC1);
      cv::Mat gy = cv::Mat::zeros(h.size(), CV_32FC1);
      for (int y = 0; y < rows; ++y) {
        const float* p = h.ptr<float>(y);
        const float* f = phi.ptr<float>(y);
        float* ox = gx.ptr<float>(y);
        for (int x = 0; x + 1 < w; ++x) {
          ox[x] = (p[x + 1] - p[x]) * 0.5f * (f[x] + f[x + 1]);
        }
        if (y + 1 < rows) {
          const float* ps = h.ptr<float>(y + 1);
          const float* fs = phi.ptr<float>(y + 1);
          float* oy = gy.ptr<float>(y);
          for (int x = 0; x < w; ++x) {
            oy[x] = (ps[x] - p[x]) * 0.5f * (f[x] + fs[x]);
          }
        }
      }
      cv::Mat div(h.size(), CV_32FC1);
      for (int y = 0; y < rows; ++y) {
        const float* ox = gx.ptr<float>(y);
        const float* oy = gy.ptr<float>(y);
        const float* oyn = y > 0 ? gy.ptr<float>(y - 1) : nullptr;
        float* d = div.ptr<float>(y);
        for (int x = 0; x < w; ++x) {
          float s = ox[x] + oy[x];
          if (x > 0) s -= ox[x - 1];
          if (oyn != nullptr) s -= oyn[x];
          d[x] = s;
        }
      }
      ASSIGN_OR_RETURN(cv::Mat solved, SolvePoissonNeumann(div));
      // The Poisson solution is defined up to a constant. Anchor it on the
      // mid-tones: the median of (H - I) over the pixels whose H lies between
      // the pooled 40th and 60th percentiles is made zero. In a stereo pair
      // those are mostly the same scene points in both views, so both views
      // get the same constant (a mean or a plain median is pulled by content
      // that enters one view only, e.g. a lamp at the border).
      cv::Mat result;
      solved.convertTo(result, CV_32F);
      out[v] = result + MedianDifference(h, result, band_lo, band_hi);
    }
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("Fattal: ", e.what()));
  }
}

}  // namespace

absl::StatusOr<std::vector<cv::Mat>> FattalCompress(
    const std::vector<cv::Mat>& log_lum, const FattalOptions& params) {
  if (log_lum.empty()) return absl::InvalidArgumentError("no views");
  if (absl::Status s = params.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("Fattal: ", s.message()));
  }
  for (const cv::Mat& m : log_lum) {
    if (m.empty() || m.type() != CV_32FC1) {
      return absl::InvalidArgumentError("log luminance must be CV_32FC1");
    }
  }
  int widest = 0;
  for (const cv::Mat& m : log_lum) widest = std::max(widest, m.cols);
  if (params.solve_width == 0 || widest <= params.solve_width) {
    return CompressAtOwnSize(log_lum, params);
  }
  try {
    // Every view at the same scale, so that they still share statistics.
    const double scale = static_cast<double>(params.solve_width) / widest;
    std::vector<cv::Mat> small(log_lum.size());
    for (size_t v = 0; v < log_lum.size(); ++v) {
      const cv::Size size(
          std::max(1, static_cast<int>(std::lround(log_lum[v].cols * scale))),
          std::max(1, static_cast<int>(std::lround(log_lum[v].rows * scale))));
      cv::resize(log_lum[v], small[v], size, 0, 0, cv::INTER_AREA);
    }
    ASSIGN_OR_RETURN(const std::vector<cv::Mat> compressed,
                     CompressAtOwnSize(small, params));
    std::vector<cv::Mat> out(log_lum.size());
    for (size_t v = 0; v < log_lum.size(); ++v) {
      // Bilinear: a change that followed the full-size edges (a guided
      // filter) moved texture with it and matched worse (lab-lamp, 1200
      // px: bad-1px 75.7 % against 59.8 %).
      const cv::Mat change = compressed[v] - small[v];
      cv::Mat up;
      cv::resize(change, up, log_lum[v].size(), 0, 0, cv::INTER_LINEAR);
      out[v] = log_lum[v] + up;
    }
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("Fattal: ", e.what()));
  }
}

}  // namespace hdrstereo::tonemap
