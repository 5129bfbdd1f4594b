// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/wls_filter.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/core/hal/hal.hpp>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/filters/mat_checks.h"

namespace hdrstereo::filters {
namespace {

// fn(y) for every row, split over OpenCV's thread pool when large.
template <typename Fn>
void ParallelRows(int rows, const Fn& fn) {
  if (rows < 64) {
    for (int y = 0; y < rows; ++y) fn(y);
    return;
  }
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) fn(y);
  });
}

// Aggregation multigrid V-cycle used as a CG preconditioner. Level l + 1
// merges 2x2 cells of level l (piecewise-constant prolongation P, restriction
// P^T, Galerkin coarse operator P^T A P), which keeps the "identity part +
// weighted 5-point Laplacian" form: the identity parts of the four cells add
// up, and the coarse coupling between two blocks is the sum of the fine
// couplings that cross their common side (couplings inside a block cancel).
// Smoothing: one forward Gauss-Seidel sweep before, one backward after (so
// the cycle is a symmetric operator, as CG needs); the coarsest level gets a
// fixed number of symmetric sweeps.
class Multigrid {
 public:
  struct Level {
    int w = 0, h = 0;
    std::vector<float> ident, ax, ay, inv_diag;
    mutable std::vector<float> x, b, r, snap;
  };

  Multigrid(int w, int h, const std::vector<float>& ax,
            const std::vector<float>& ay) {
    Level fine;
    fine.w = w;
    fine.h = h;
    fine.ident.assign(static_cast<size_t>(w) * h, 1.0f);
    fine.ax = ax;
    fine.ay = ay;
    Finish(fine);
    levels_.push_back(std::move(fine));
    while (levels_.back().w > 4 && levels_.back().h > 4) {
      levels_.push_back(Coarsen(levels_.back()));
    }
  }

  // z = M^-1 r.
  void Apply(const std::vector<float>& r, std::vector<float>& z) const {
    Level& top = const_cast<Level&>(levels_[0]);
    top.b = r;
    Cycle(0);
    z = top.x;
  }

 private:
  static void Finish(Level& l) {
    const size_t n = static_cast<size_t>(l.w) * l.h;
    l.inv_diag.resize(n);
    for (int y = 0; y < l.h; ++y) {
      for (int x = 0; x < l.w; ++x) {
        const size_t i = static_cast<size_t>(y) * l.w + x;
        float d = l.ident[i] + l.ax[i] + l.ay[i];
        if (x > 0) d += l.ax[i - 1];
        if (y > 0) d += l.ay[i - l.w];
        l.inv_diag[i] = 1.0f / d;
      }
    }
    l.x.assign(n, 0.0f);
    l.b.assign(n, 0.0f);
    l.r.assign(n, 0.0f);
  }

  static Level Coarsen(const Level& f) {
    Level c;
    c.w = (f.w + 1) / 2;
    c.h = (f.h + 1) / 2;
    const size_t n = static_cast<size_t>(c.w) * c.h;
    c.ident.assign(n, 0.0f);
    c.ax.assign(n, 0.0f);
    c.ay.assign(n, 0.0f);
    for (int y = 0; y < f.h; ++y) {
      for (int x = 0; x < f.w; ++x) {
        const size_t i = static_cast<size_t>(y) * f.w + x;
        const size_t ci = static_cast<size_t>(y / 2) * c.w + x / 2;
        c.ident[ci] += f.ident[i];
        // Fine couplings leaving the block through its east / south side.
        if (x % 2 == 1 && x + 1 < f.w) c.ax[ci] += f.ax[i];
        if (y % 2 == 1 && y + 1 < f.h) c.ay[ci] += f.ay[i];
      }
    }
    Finish(c);
    return c;
  }

  // One Gauss-Seidel sweep. The rows are cut into a fixed number of blocks
  // swept concurrently (block Gauss-Seidel: a block sees its neighbours'
  // rows as they were before the sweep, snapshotted first, so the result
  // does not depend on the thread count or timing). Per row, everything but
  // the neighbour updated just before (west when going forward, east when
  // going backward) is gathered in a vectorisable pass; the recurrence is
  // then one multiply-add per pixel.
  static void Sweep(const Level& l, bool forward) {
    const int w = l.w, h = l.h;
    const int blocks = h >= 128 ? kSweepBlocks : 1;
    l.snap.resize(static_cast<size_t>(2 * blocks) * w);
    auto first = [&](int k) { return k * h / blocks; };
    for (int k = 0; k < blocks; ++k) {
      const int y0 = first(k), y1 = first(k + 1);
      if (y0 > 0) {
        std::copy_n(&l.x[static_cast<size_t>(y0 - 1) * w], w,
                    &l.snap[static_cast<size_t>(2 * k) * w]);
      }
      if (y1 < h) {
        std::copy_n(&l.x[static_cast<size_t>(y1) * w], w,
                    &l.snap[static_cast<size_t>(2 * k + 1) * w]);
      }
    }
    // Fills the scratch row t of row y (block k) with everything but the
    // recurrence term.
    auto gather = [&](int k, int y) {
      const int y0 = first(k), y1 = first(k + 1);
      const size_t row = static_cast<size_t>(y) * w;
      float* x = &l.x[row];
      float* t = &l.r[row];  // scratch (r is recomputed after sweeps)
      const float* b = &l.b[row];
      const float* ax = &l.ax[row];
      for (int px = 0; px < w; ++px) t[px] = b[px];
      if (y > 0) {
        const float* ay_n = &l.ay[row - w];
        const float* xn =
            y == y0 ? &l.snap[static_cast<size_t>(2 * k) * w] : x - w;
        for (int px = 0; px < w; ++px) t[px] += ay_n[px] * xn[px];
      }
      if (y + 1 < h) {
        const float* ay = &l.ay[row];
        const float* xs =
            y == y1 - 1 ? &l.snap[static_cast<size_t>(2 * k + 1) * w] : x + w;
        for (int px = 0; px < w; ++px) t[px] += ay[px] * xs[px];
      }
      if (forward) {
        for (int px = 0; px + 1 < w; ++px) t[px] += ax[px] * x[px + 1];
      } else {
        for (int px = 1; px < w; ++px) t[px] += ax[px - 1] * x[px - 1];
      }
    };
    // The recurrence of one row, or of two rows interleaved (independent
    // chains: twice the instruction-level parallelism).
    auto recur = [&](int ya, int yb) {
      const size_t ra = static_cast<size_t>(ya) * w;
      const size_t rb = static_cast<size_t>(yb < 0 ? ya : yb) * w;
      float* xa = &l.x[ra];
      float* xb = &l.x[rb];
      const float* ta = &l.r[ra];
      const float* tb = &l.r[rb];
      const float* axa = &l.ax[ra];
      const float* axb = &l.ax[rb];
      const float* ia = &l.inv_diag[ra];
      const float* ib = &l.inv_diag[rb];
      if (yb < 0) {
        if (forward) {
          float prev = 0.0f, a_prev = 0.0f;
          for (int px = 0; px < w; ++px) {
            prev = (ta[px] + a_prev * prev) * ia[px];
            xa[px] = prev;
            a_prev = axa[px];
          }
        } else {
          float next = 0.0f;
          for (int px = w - 1; px >= 0; --px) {
            next = (ta[px] + axa[px] * next) * ia[px];
            xa[px] = next;
          }
        }
        return;
      }
      if (forward) {
        float pa = 0.0f, pb = 0.0f, aa = 0.0f, ab = 0.0f;
        for (int px = 0; px < w; ++px) {
          pa = (ta[px] + aa * pa) * ia[px];
          pb = (tb[px] + ab * pb) * ib[px];
          xa[px] = pa;
          xb[px] = pb;
          aa = axa[px];
          ab = axb[px];
        }
      } else {
        float na = 0.0f, nb = 0.0f;
        for (int px = w - 1; px >= 0; --px) {
          na = (ta[px] + axa[px] * na) * ia[px];
          nb = (tb[px] + axb[px] * nb) * ib[px];
          xa[px] = na;
          xb[px] = nb;
        }
      }
    };
    // Sweeps block ka, and block kb (if >= 0) interleaved with it.
    auto sweep_blocks = [&](int ka, int kb) {
      const int na = first(ka + 1) - first(ka);
      const int nb = kb < 0 ? 0 : first(kb + 1) - first(kb);
      auto row_of = [&](int k, int n, int i) {
        return forward ? first(k) + i : first(k) + n - 1 - i;
      };
      for (int i = 0; i < std::max(na, nb); ++i) {
        const int ya = i < na ? row_of(ka, na, i) : -1;
        const int yb = i < nb ? row_of(kb, nb, i) : -1;
        if (ya >= 0) gather(ka, ya);
        if (yb >= 0) gather(kb, yb);
        if (ya >= 0 && yb >= 0) {
          recur(ya, yb);
        } else {
          recur(ya >= 0 ? ya : yb, -1);
        }
      }
    };
    if (blocks == 1) {
      sweep_blocks(0, -1);
    } else {
      const int pairs = blocks / 2;
      cv::parallel_for_(cv::Range(0, pairs), [&](const cv::Range& r) {
        for (int k = r.start; k < r.end; ++k) sweep_blocks(k, k + pairs);
      });
    }
  }

  // r = b - A x in the cancellation-free form.
  static void Residual(const Level& l) {
    const int w = l.w, h = l.h;
    ParallelRows(h, [&](int y) {
      const size_t row = static_cast<size_t>(y) * w;
      const float* x = &l.x[row];
      const float* ax = &l.ax[row];
      const float* id = &l.ident[row];
      const float* b = &l.b[row];
      float* r = &l.r[row];
      for (int px = 0; px < w; ++px) r[px] = b[px] - id[px] * x[px];
      for (int px = 0; px + 1 < w; ++px) {
        const float f = ax[px] * (x[px] - x[px + 1]);
        r[px] -= f;
        r[px + 1] += f;
      }
      if (y + 1 < h) {
        const float* ay = &l.ay[row];
        const float* xs = x + w;
        for (int px = 0; px < w; ++px) r[px] -= ay[px] * (x[px] - xs[px]);
      }
      if (y > 0) {
        const float* ay_n = &l.ay[row - w];
        const float* xn = x - w;
        for (int px = 0; px < w; ++px) r[px] -= ay_n[px] * (x[px] - xn[px]);
      }
    });
  }

  void Cycle(size_t k) const {
    const Level& l = levels_[k];
    std::fill(l.x.begin(), l.x.end(), 0.0f);
    if (k + 1 == levels_.size()) {
      for (int s = 0; s < 20; ++s) {
        Sweep(l, true);
        Sweep(l, false);
      }
      return;
    }
    for (int s = 0; s < kNu; ++s) Sweep(l, true);
    Residual(l);
    const Level& c = levels_[k + 1];
    // Restriction P^T: each coarse row sums its two fine rows.
    ParallelRows(c.h, [&](int cy) {
      float* cb = &c.b[static_cast<size_t>(cy) * c.w];
      std::fill_n(cb, c.w, 0.0f);
      for (int y = 2 * cy; y < std::min(2 * cy + 2, l.h); ++y) {
        const float* r = &l.r[static_cast<size_t>(y) * l.w];
        for (int x = 0; x < l.w; ++x) cb[x / 2] += r[x];
      }
    });
    Cycle(k + 1);
    // Prolongation P: piecewise constant.
    ParallelRows(l.h, [&](int y) {
      float* x_row = &l.x[static_cast<size_t>(y) * l.w];
      const float* cx = &c.x[static_cast<size_t>(y / 2) * c.w];
      for (int x = 0; x < l.w; ++x) x_row[x] += kOmega * cx[x / 2];
    });
    for (int s = 0; s < kNu; ++s) Sweep(l, false);
  }

  // Measured on 256x192 test images: one sweep and no over-correction is
  // fastest (two sweeps: fewer iterations, more time; over-correcting the
  // coarse step by 1.5 .. 2 needs more iterations).
  static constexpr float kOmega = 1.0f;
  static constexpr int kNu = 1;
  // Row blocks of the parallel Gauss-Seidel sweep (levels >= 128 rows).
  static constexpr int kSweepBlocks = 8;
  std::vector<Level> levels_;
};

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
    if (o.preconditioner == WlsOptions::Preconditioner::kMultigrid) {
      multigrid_ = std::make_unique<Multigrid>(w_, h_, ax_, ay_);
    } else {
      BuildPreconditioner();
    }
  }

  size_t size() const { return diag_.size(); }

  // out = A v; returns v . out. Written as v + sum of w (v - v_neighbour)
  // rather than diag * v - sum of w v_neighbour: with weights up to 1 / small
  // = 1e4 the latter cancels catastrophically in float.
  double Apply(const std::vector<float>& v, std::vector<float>& out) const {
    row_dots_.resize(h_);
    ParallelRows(h_, [&](int y) {
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
      row_dots_[y] = s;
    });
    double dot = 0.0;  // summed in row order: deterministic
    for (float d : row_dots_) dot += d;
    return dot;
  }

  // z = M^-1 r with M the incomplete Cholesky factorisation.
  void Precondition(const std::vector<float>& r, std::vector<float>& z) const {
    if (multigrid_) {
      multigrid_->Apply(r, z);
      return;
    }
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
  std::unique_ptr<Multigrid> multigrid_;
  mutable std::vector<float> scratch_;
  mutable std::vector<float> row_dots_;
};

// Chunked partial sums (fixed chunks, summed in order: deterministic).
double Dot(const std::vector<float>& a, const std::vector<float>& b) {
  constexpr size_t kChunk = 4096;
  const size_t n = a.size();
  const int chunks = static_cast<int>((n + kChunk - 1) / kChunk);
  std::vector<double> part(chunks);
  cv::parallel_for_(cv::Range(0, chunks), [&](const cv::Range& r) {
    for (int c = r.start; c < r.end; ++c) {
      const size_t lo = c * kChunk, hi = std::min(n, lo + kChunk);
      float s = 0.0f;
      for (size_t k = lo; k < hi; ++k) s += a[k] * b[k];
      part[c] = s;
    }
  });
  double s = 0.0;
  for (double p : part) s += p;
  return s;
}

// out[i] = f(i) for all i, in parallel chunks.
template <typename Fn>
void ParallelFor(size_t n, const Fn& f) {
  constexpr size_t kChunk = 16384;
  const int chunks = static_cast<int>((n + kChunk - 1) / kChunk);
  cv::parallel_for_(cv::Range(0, chunks), [&](const cv::Range& r) {
    const size_t lo = r.start * kChunk, hi = std::min(n, r.end * kChunk);
    for (size_t i = lo; i < hi; ++i) f(i);
  });
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
    ParallelFor(n, [&](size_t i) {
      u[i] += step * s[i];
      r[i] -= step * q[i];
    });
    r_norm = std::sqrt(Dot(r, r));
    report.iterations = it;
    report.relative_residual = r_norm / b_norm;
    if (report.relative_residual <= o.tolerance) break;
    a.Precondition(r, z);
    const double rho_new = Dot(r, z);
    const float beta = static_cast<float>(rho_new / rho);
    rho = rho_new;
    ParallelFor(n, [&](size_t i) { s[i] = z[i] + beta * s[i]; });
  }
  return report;
}

}  // namespace

absl::StatusOr<cv::Mat> WlsFilter(const cv::Mat& src, const cv::Mat& guide,
                                  const WlsOptions& options,
                                  WlsReport* report) {
  RETURN_IF_ERROR(CheckImage(src, "WLS input", /*float_only=*/false, {}));
  const cv::Mat& g = guide.empty() ? src : guide;
  RETURN_IF_ERROR(CheckImage(g, "WLS guide", /*float_only=*/false, {1}));
  if (g.size() != src.size()) {
    return absl::InvalidArgumentError("WLS input and guide differ in size");
  }
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("WLS: ", s.message()));
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
