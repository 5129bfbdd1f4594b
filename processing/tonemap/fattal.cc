// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/tonemap/fattal.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

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
      const float gx = (p[std::min(x + 1, w - 1)] - p[std::max(x - 1, 0)]) * scale;
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

}  // namespace

absl::StatusOr<cv::Mat> SolvePoissonNeumann(const cv::Mat& f) {
  if (f.empty() || f.channels() != 1 ||
      (f.depth() != CV_32F && f.depth() != CV_64F)) {
    return absl::InvalidArgumentError(
        "Poisson right-hand side must be a non-empty CV_32FC1/CV_64FC1");
  }
  try {
    const int w = f.cols, h = f.rows;
    // cv::dct needs even sizes: pad by one replicated row / column with zero
    // divergence, which leaves the Neumann solution on the original domain
    // unchanged (the padded pixel just copies its neighbour).
    const int pw = w + (w % 2), ph = h + (h % 2);
    cv::Mat rhs = cv::Mat::zeros(ph, pw, CV_64FC1);
    f.convertTo(rhs(cv::Rect(0, 0, w, h)), CV_64F);
    cv::Mat spec;
    cv::dct(rhs, spec);
    std::vector<double> cx(pw), cy(ph);
    for (int u = 0; u < pw; ++u) {
      cx[u] = 2.0 * std::cos(std::numbers::pi * u / pw) - 2.0;
    }
    for (int v = 0; v < ph; ++v) {
      cy[v] = 2.0 * std::cos(std::numbers::pi * v / ph) - 2.0;
    }
    for (int v = 0; v < ph; ++v) {
      double* s = spec.ptr<double>(v);
      for (int u = 0; u < pw; ++u) {
        const double lambda = cx[u] + cy[v];
        s[u] = (u == 0 && v == 0) ? 0.0 : s[u] / lambda;
      }
    }
    cv::Mat sol;
    cv::dct(spec, sol, cv::DCT_INVERSE);
    cv::Mat out = sol(cv::Rect(0, 0, w, h)).clone();
    out -= cv::mean(out)[0];
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("Poisson solve: ", e.what()));
  }
}

absl::StatusOr<std::vector<cv::Mat>> FattalCompress(
    const std::vector<cv::Mat>& log_lum, const FattalParams& params) {
  if (log_lum.empty()) return absl::InvalidArgumentError("no views");
  if (!(params.alpha > 0) || !(params.beta > 0) || params.beta > 1.0 ||
      params.min_level_size < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "Fattal needs alpha > 0, 0 < beta <= 1, min_level_size >= 2; got ",
        params.alpha, ", ", params.beta, ", ", params.min_level_size));
  }
  for (const cv::Mat& m : log_lum) {
    if (m.empty() || m.type() != CV_32FC1) {
      return absl::InvalidArgumentError("log luminance must be CV_32FC1");
    }
  }
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
      absl::StatusOr<cv::Mat> solved = SolvePoissonNeumann(div);
      if (!solved.ok()) return solved.status();
      cv::Mat result;
      solved->convertTo(result, CV_32F, 1.0, cv::mean(h)[0]);
      out[v] = result;
    }
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("Fattal: ", e.what()));
  }
}

}  // namespace hdrstereo::tonemap
