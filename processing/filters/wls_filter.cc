// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/wls_filter.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/hal/hal.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/filters/mat_checks.h"

namespace hdrstereo::filters {
namespace {

// The system matrix: diag_ on the diagonal, -ax_[i] between pixel i and its
// east neighbour, -ay_[i] between pixel i and its south neighbour (zero on the
// last column / row).
class WlsSystem {
 public:
  WlsSystem(const cv::Mat& guide, const WlsOptions& o)
      : w_(guide.cols), h_(guide.rows) {
    const size_t n = static_cast<size_t>(w_) * h_;
    ax_.assign(n, 0.0f);
    ay_.assign(n, 0.0f);
    diag_.assign(n, 1.0f);
    const float lambda = static_cast<float>(o.lambda);
    const float small = static_cast<float>(o.small_number);
    const float alpha = static_cast<float>(o.alpha);
    std::vector<float> buf(w_);
    auto weights = [&](float* out, int count) {
      // out[k] holds |dl| on entry, lambda / (|dl|^alpha + small) on exit.
      for (int k = 0; k < count; ++k) {
        buf[k] = std::max(out[k], 1e-20f);
      }
      cv::hal::log32f(buf.data(), buf.data(), count);
      for (int k = 0; k < count; ++k) buf[k] *= alpha;
      cv::hal::exp32f(buf.data(), buf.data(), count);
      for (int k = 0; k < count; ++k) out[k] = lambda / (buf[k] + small);
    };
    for (int y = 0; y < h_; ++y) {
      const float* g = guide.ptr<float>(y);
      float* ax = &ax_[static_cast<size_t>(y) * w_];
      for (int x = 0; x + 1 < w_; ++x) ax[x] = std::fabs(g[x + 1] - g[x]);
      weights(ax, w_ - 1);
      if (y + 1 < h_) {
        const float* gs = guide.ptr<float>(y + 1);
        float* ay = &ay_[static_cast<size_t>(y) * w_];
        for (int x = 0; x < w_; ++x) ay[x] = std::fabs(gs[x] - g[x]);
        weights(ay, w_);
      }
    }
    for (int y = 0; y < h_; ++y) {
      for (int x = 0; x < w_; ++x) {
        const size_t i = static_cast<size_t>(y) * w_ + x;
        float d = 1.0f + ax_[i] + ay_[i];
        if (x > 0) d += ax_[i - 1];
        if (y > 0) d += ay_[i - w_];
        diag_[i] = d;
      }
    }
    BuildPreconditioner();
  }

  size_t size() const { return diag_.size(); }

  // out = A v; returns v . out. Written as v + sum of w (v - v_neighbour)
  // rather than diag * v - sum of w v_neighbour: with weights up to 1 / small
  // = 1e4 the latter cancels catastrophically in float.
  double Apply(const std::vector<float>& v, std::vector<float>& out) const {
    double dot = 0.0;
    for (int y = 0; y < h_; ++y) {
      const size_t row = static_cast<size_t>(y) * w_;
      const float* pv = &v[row];
      const float* ax = &ax_[row];
      const float* ay = &ay_[row];
      float* o = &out[row];
      for (int x = 0; x < w_; ++x) o[x] = pv[x];
      for (int x = 0; x + 1 < w_; ++x) {
        const float f = ax[x] * (pv[x] - pv[x + 1]);
        o[x] += f;
        o[x + 1] -= f;
      }
      if (y + 1 < h_) {
        const float* pv_s = pv + w_;
        for (int x = 0; x < w_; ++x) o[x] += ay[x] * (pv[x] - pv_s[x]);
      }
      if (y > 0) {
        const float* pv_n = pv - w_;
        const float* ay_n = ay - w_;
        for (int x = 0; x < w_; ++x) o[x] += ay_n[x] * (pv[x] - pv_n[x]);
      }
      float s = 0.0f;
      for (int x = 0; x < w_; ++x) s += o[x] * pv[x];
      dot += s;
    }
    return dot;
  }

  // z = M^-1 r with M the incomplete Cholesky factorisation.
  void Precondition(const std::vector<float>& r, std::vector<float>& z) const {
    std::vector<float>& q = scratch_;
    q.resize(size());
    for (int y = 0; y < h_; ++y) {
      const size_t row = static_cast<size_t>(y) * w_;
      for (int x = 0; x < w_; ++x) {
        const size_t i = row + x;
        float t = r[i];
        if (x > 0) t += ax_[i - 1] * p_[i - 1] * q[i - 1];
        if (y > 0) t += ay_[i - w_] * p_[i - w_] * q[i - w_];
        q[i] = t * p_[i];
      }
    }
    for (int y = h_ - 1; y >= 0; --y) {
      const size_t row = static_cast<size_t>(y) * w_;
      for (int x = w_ - 1; x >= 0; --x) {
        const size_t i = row + x;
        float t = q[i];
        if (x + 1 < w_) t += ax_[i] * p_[i] * z[i + 1];
        if (y + 1 < h_) t += ay_[i] * p_[i] * z[i + w_];
        z[i] = t * p_[i];
      }
    }
  }

 private:
  void BuildPreconditioner() {
    constexpr double kTau = 0.0;  // plain IC(0): fewer iterations than MIC here
    constexpr double kSigma = 0.25;
    p_.assign(size(), 0.0f);
    for (int y = 0; y < h_; ++y) {
      for (int x = 0; x < w_; ++x) {
        const size_t i = static_cast<size_t>(y) * w_ + x;
        const double d = diag_[i];
        double e = d;
        if (x > 0) {
          const double a = ax_[i - 1], p = p_[i - 1];
          const double ay_w = ay_[i - 1];
          e -= (a * p) * (a * p) + kTau * a * ay_w * p * p;
        }
        if (y > 0) {
          const double a = ay_[i - w_], p = p_[i - w_];
          const double ax_n = ax_[i - w_];
          e -= (a * p) * (a * p) + kTau * a * ax_n * p * p;
        }
        if (e < kSigma * d) e = d;
        p_[i] = static_cast<float>(1.0 / std::sqrt(e));
      }
    }
  }

  int w_, h_;
  std::vector<float> ax_, ay_, diag_, p_;
  mutable std::vector<float> scratch_;
};

double Dot(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0.0;
  const size_t n = a.size();
  size_t i = 0;
  for (; i + 1024 <= n; i += 1024) {
    float part = 0.0f;
    for (size_t k = i; k < i + 1024; ++k) part += a[k] * b[k];
    s += part;
  }
  for (; i < n; ++i) s += static_cast<double>(a[i]) * b[i];
  return s;
}

// Solves A u = b in place (u holds the initial guess).
WlsReport SolveCg(const WlsSystem& a, const std::vector<float>& b,
                  std::vector<float>& u, const WlsOptions& o) {
  const size_t n = a.size();
  std::vector<float> r(n), z(n), s(n), q(n);
  a.Apply(u, q);
  for (size_t i = 0; i < n; ++i) r[i] = b[i] - q[i];
  const double b_norm = std::sqrt(Dot(b, b));
  WlsReport report;
  if (b_norm == 0.0) {
    std::fill(u.begin(), u.end(), 0.0f);
    return report;
  }
  double r_norm = std::sqrt(Dot(r, r));
  report.relative_residual = r_norm / b_norm;
  if (report.relative_residual <= o.tolerance) return report;
  a.Precondition(r, z);
  s = z;
  double rho = Dot(r, z);
  for (int it = 1; it <= o.max_iterations; ++it) {
    const double sq = a.Apply(s, q);
    if (!(sq > 0.0)) break;
    const float step = static_cast<float>(rho / sq);
    for (size_t i = 0; i < n; ++i) {
      u[i] += step * s[i];
      r[i] -= step * q[i];
    }
    r_norm = std::sqrt(Dot(r, r));
    report.iterations = it;
    report.relative_residual = r_norm / b_norm;
    if (report.relative_residual <= o.tolerance) break;
    a.Precondition(r, z);
    const double rho_new = Dot(r, z);
    const float beta = static_cast<float>(rho_new / rho);
    rho = rho_new;
    for (size_t i = 0; i < n; ++i) s[i] = z[i] + beta * s[i];
  }
  return report;
}

}  // namespace

absl::StatusOr<cv::Mat> WlsFilter(const cv::Mat& src, const cv::Mat& guide,
                                  const WlsOptions& options,
                                  WlsReport* report) {
  if (absl::Status s = CheckImage(src, "WLS input", /*float_only=*/false, {});
      !s.ok()) {
    return s;
  }
  const cv::Mat& g = guide.empty() ? src : guide;
  if (absl::Status s = CheckImage(g, "WLS guide", /*float_only=*/false, {1});
      !s.ok()) {
    return s;
  }
  if (g.size() != src.size()) {
    return absl::InvalidArgumentError("WLS input and guide differ in size");
  }
  if (!(options.alpha > 0) || !(options.lambda >= 0) ||
      !(options.small_number > 0) || !(options.tolerance > 0) ||
      options.max_iterations < 1 || !std::isfinite(options.alpha) ||
      !std::isfinite(options.lambda)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "WLS needs alpha > 0, lambda >= 0, small_number > 0, tolerance > 0, "
        "max_iterations >= 1; got alpha=",
        options.alpha, " lambda=", options.lambda));
  }
  try {
    const cv::Mat gf = ToFloat(g);
    const WlsSystem system(gf, options);
    std::vector<cv::Mat> planes;
    cv::split(ToFloat(src), planes);
    WlsReport worst;
    const size_t n = system.size();
    std::vector<float> b(n), u(n);
    for (cv::Mat& p : planes) {
      for (int y = 0; y < p.rows; ++y) {
        const float* row = p.ptr<float>(y);
        std::copy(row, row + p.cols, &b[static_cast<size_t>(y) * p.cols]);
      }
      u = b;
      const WlsReport r = SolveCg(system, b, u, options);
      worst.iterations = std::max(worst.iterations, r.iterations);
      worst.relative_residual =
          std::max(worst.relative_residual, r.relative_residual);
      cv::Mat out(p.size(), CV_32FC1);
      for (int y = 0; y < p.rows; ++y) {
        std::copy(&u[static_cast<size_t>(y) * p.cols],
                  &u[static_cast<size_t>(y + 1) * p.cols], out.ptr<float>(y));
      }
      p = out;
    }
    if (report != nullptr) *report = worst;
    cv::Mat out;
    cv::merge(planes, out);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("WLS filter: ", e.what()));
  }
}

}  // namespace hdrstereo::filters
