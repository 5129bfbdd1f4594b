// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/disparity.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace hdrstereo::structured_light {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// Intercept at t = 0 of the least-squares line through (t_i, v_i).
double FitIntercept(double n, double st, double stt, double sv, double stv) {
  const double det = n * stt - st * st;
  if (n < 2 || std::abs(det) < 1e-9) return sv / n;
  return (sv * stt - st * stv) / det;
}

// A piece of a scanline between two pixel positions over which the
// continuous codes change linearly.
struct Piece {
  float x0, x1;
  float u0, u1;
  float v0, v1;
  float h;  // half the row range the ends stand for (coarse codes)
};

bool Connected(float ua, float va, float ub, float vb, float step) {
  return std::abs(ua - ub) <= step && std::abs(va - vb) <= step;
}

// Pieces of scanline y of `codes` (including half-pixel extrapolations at
// the ends of each surface run), indexed by the integer projector columns
// they span.
void BuildPieces(const SubpixelCodes& codes, int y, int step,
                 std::vector<Piece>* pieces,
                 std::vector<std::pair<int, int>>* index) {
  pieces->clear();
  index->clear();
  const float* u = codes.column.ptr<float>(y);
  const float* v = codes.row.ptr<float>(y);
  const float* h =
      codes.row_halfwidth.empty() ? nullptr : codes.row_halfwidth.ptr<float>(y);
  const int w = codes.column.cols;
  auto half = [&](int a, int b) {
    return h == nullptr ? 0.0f : std::max(h[a], h[b]);
  };
  auto linked = [&](int a, int b) {
    return a >= 0 && b < w && !std::isnan(u[a]) && !std::isnan(u[b]) &&
           Connected(u[a], v[a], u[b], v[b], step + 2 * half(a, b));
  };
  for (int x = 0; x < w; ++x) {
    if (std::isnan(u[x])) continue;
    const bool left_link = linked(x - 1, x);
    const bool right_link = linked(x, x + 1);
    if (right_link) {
      pieces->push_back({static_cast<float>(x), static_cast<float>(x + 1), u[x],
                         u[x + 1], v[x], v[x + 1], half(x, x + 1)});
    }
    // Half a pixel beyond the ends of a run, with the run's local slope.
    if (left_link && !right_link) {
      const float du = u[x] - u[x - 1], dv = v[x] - v[x - 1];
      pieces->push_back({static_cast<float>(x), x + 0.5f, u[x],
                         u[x] + 0.5f * du, v[x], v[x] + 0.5f * dv,
                         half(x - 1, x)});
    }
    if (right_link && !left_link) {
      const float du = u[x + 1] - u[x], dv = v[x + 1] - v[x];
      pieces->push_back({x - 0.5f, static_cast<float>(x), u[x] - 0.5f * du,
                         u[x], v[x] - 0.5f * dv, v[x], half(x, x + 1)});
    }
  }
  for (size_t i = 0; i < pieces->size(); ++i) {
    const Piece& p = (*pieces)[i];
    const int k0 = static_cast<int>(std::floor(std::min(p.u0, p.u1)));
    const int k1 = static_cast<int>(std::floor(std::max(p.u0, p.u1)));
    for (int k = k0; k <= k1; ++k) {
      index->emplace_back(k, static_cast<int>(i));
    }
  }
  std::sort(index->begin(), index->end());
}

// Matches every pixel of `from` on its scanline in `to`. `sign` = +1 for
// left -> right (d = x - x_to), -1 for right -> left (d = x_to - x).
int MatchScanlines(const SubpixelCodes& from, const SubpixelCodes& to, int sign,
                   const MatchOptions& o, int min_d, int max_d,
                   cv::Mat* disparity) {
  *disparity = cv::Mat(from.column.size(), CV_32FC1, cv::Scalar(kInf));
  std::vector<int> matched_rows(from.column.rows, 0);
  cv::parallel_for_(cv::Range(0, from.column.rows), [&](const cv::Range& r) {
    std::vector<Piece> pieces;
    std::vector<std::pair<int, int>> index;
    for (int y = r.start; y < r.end; ++y) {
      BuildPieces(to, y, o.max_code_step, &pieces, &index);
      const float* u = from.column.ptr<float>(y);
      const float* v = from.row.ptr<float>(y);
      float* out = disparity->ptr<float>(y);
      int matched = 0;
      for (int x = 0; x < from.column.cols; ++x) {
        if (std::isnan(u[x])) continue;
        const int k = static_cast<int>(std::floor(u[x]));
        auto it =
            std::lower_bound(index.begin(), index.end(), std::make_pair(k, -1));
        const float h_from = from.row_halfwidth.empty()
                                 ? 0.0f
                                 : from.row_halfwidth.ptr<float>(y)[x];
        double best_dv = std::numeric_limits<double>::infinity();
        float best = kInf;
        for (; it != index.end() && it->first == k; ++it) {
          const Piece& p = pieces[it->second];
          const float lo = std::min(p.u0, p.u1), hi = std::max(p.u0, p.u1);
          if (u[x] < lo || u[x] > hi || hi - lo <= 0) continue;
          const float a = (u[x] - p.u0) / (p.u1 - p.u0);
          const float xo = p.x0 + a * (p.x1 - p.x0);
          const float vo = p.v0 + a * (p.v1 - p.v0);
          const float d = sign * (x - xo);
          if (d < min_d || d > max_d) continue;
          const double dv = std::abs(vo - v[x]);
          // Coarse rows agree when their ranges come within the tolerance.
          const double limit = o.max_row_difference + h_from + p.h;
          if (dv <= limit && dv <= best_dv) {
            best_dv = dv;
            best = d;
          }
        }
        if (std::isfinite(best)) {
          out[x] = best;
          ++matched;
        }
      }
      matched_rows[y] = matched;
    }
  });
  int total = 0;
  for (int m : matched_rows) total += m;
  return total;
}

// Left-right check: keeps a pixel of `disparity` when the other view,
// at x - sign * d, has a disparity within `tol` (either neighbouring pixel).
int CrossCheck(cv::Mat* disparity, const cv::Mat& other, int sign, double tol) {
  int rejected = 0;
  for (int y = 0; y < disparity->rows; ++y) {
    float* d = disparity->ptr<float>(y);
    const float* o = other.ptr<float>(y);
    for (int x = 0; x < disparity->cols; ++x) {
      if (!std::isfinite(d[x])) continue;
      const double xo = x - sign * d[x];
      const int x0 = static_cast<int>(std::floor(xo));
      bool ok = false;
      for (int xi = x0; xi <= x0 + 1 && !ok; ++xi) {
        if (xi >= 0 && xi < other.cols && std::isfinite(o[xi]) &&
            std::abs(o[xi] - d[x]) <= tol) {
          ok = true;
        }
      }
      if (!ok) {
        d[x] = kInf;
        ++rejected;
      }
    }
  }
  return rejected;
}

struct Sample {
  double x, y, d, u, v;
};

// Normalised DLT: P (3x4) with (u, v, 1) ~ P (x, y, d, 1), from `idx`, with
// per-sample weights (1 / projective depth, for reweighted refinement).
bool Dlt(const std::vector<Sample>& s, const std::vector<int>& idx,
         const std::vector<double>& weight, cv::Matx34d* p) {
  if (idx.size() < 6) return false;
  cv::Vec3d c3(0, 0, 0);
  cv::Vec2d c2(0, 0);
  for (int i : idx) {
    c3 += cv::Vec3d(s[i].x, s[i].y, s[i].d);
    c2 += cv::Vec2d(s[i].u, s[i].v);
  }
  c3 *= 1.0 / idx.size();
  c2 *= 1.0 / idx.size();
  double r3 = 0, r2 = 0;
  for (int i : idx) {
    r3 += cv::norm(cv::Vec3d(s[i].x, s[i].y, s[i].d) - c3);
    r2 += cv::norm(cv::Vec2d(s[i].u, s[i].v) - c2);
  }
  r3 /= idx.size();
  r2 /= idx.size();
  if (r3 <= 0 || r2 <= 0) return false;
  const double k3 = std::sqrt(3.0) / r3, k2 = std::sqrt(2.0) / r2;
  cv::Matx<double, 12, 12> m = cv::Matx<double, 12, 12>::zeros();
  for (int i : idx) {
    const double w = weight.empty() ? 1.0 : weight[i];
    const double xn[4] = {(s[i].x - c3[0]) * k3, (s[i].y - c3[1]) * k3,
                          (s[i].d - c3[2]) * k3, 1.0};
    const double un = (s[i].u - c2[0]) * k2, vn = (s[i].v - c2[1]) * k2;
    double a[12], b[12];
    for (int j = 0; j < 4; ++j) {
      a[j] = w * xn[j];
      a[4 + j] = 0;
      a[8 + j] = -w * un * xn[j];
      b[j] = 0;
      b[4 + j] = w * xn[j];
      b[8 + j] = -w * vn * xn[j];
    }
    for (int r = 0; r < 12; ++r) {
      for (int c = r; c < 12; ++c) m(r, c) += a[r] * a[c] + b[r] * b[c];
    }
  }
  for (int r = 0; r < 12; ++r) {
    for (int c = 0; c < r; ++c) m(r, c) = m(c, r);
  }
  cv::Mat values, vectors;
  if (!cv::eigen(cv::Mat(m), values, vectors)) return false;
  cv::Matx34d pn;
  for (int j = 0; j < 12; ++j) pn(j / 4, j % 4) = vectors.at<double>(11, j);
  const cv::Matx33d t2inv(1 / k2, 0, c2[0], 0, 1 / k2, c2[1], 0, 0, 1);
  const cv::Matx44d t3(k3, 0, 0, -k3 * c3[0], 0, k3, 0, -k3 * c3[1], 0, 0, k3,
                       -k3 * c3[2], 0, 0, 0, 1);
  *p = t2inv * pn * t3;
  return true;
}

double Reprojection(const cv::Matx34d& p, const Sample& s, double* w) {
  const cv::Vec4d x(s.x, s.y, s.d, 1.0);
  const cv::Vec3d q = p * x;
  if (w != nullptr) *w = q[2];
  if (std::abs(q[2]) < 1e-12) return std::numeric_limits<double>::infinity();
  return std::hypot(q[0] / q[2] - s.u, q[1] / q[2] - s.v);
}

}  // namespace

SubpixelCodes ComputeSubpixelCodes(const DecodedView& view,
                                   const MatchOptions& options) {
  SubpixelCodes out;
  out.column = cv::Mat(view.column.size(), CV_32FC1, cv::Scalar(kNaN));
  out.row = cv::Mat(view.column.size(), CV_32FC1, cv::Scalar(kNaN));
  out.row_halfwidth = cv::Mat(view.column.size(), CV_32FC1, cv::Scalar(0.0f));
  const int k = std::max(0, options.fit_radius);
  const int step = options.max_code_step;
  // Pixels that read only the coarse bits of a code stand for a range of
  // 2^(B - bits) projector columns (rows): their codes step by that much.
  const bool coarse = !view.column_bits.empty() && !view.row_bits.empty();
  cv::parallel_for_(cv::Range(0, view.column.rows), [&](const cv::Range& r) {
    std::vector<int> qc(view.column.cols, 1), qr(view.column.cols, 1);
    for (int y = r.start; y < r.end; ++y) {
      const int32_t* c = view.column.ptr<int32_t>(y);
      const int32_t* rw = view.row.ptr<int32_t>(y);
      float* u = out.column.ptr<float>(y);
      float* v = out.row.ptr<float>(y);
      float* hw = out.row_halfwidth.ptr<float>(y);
      const int w = view.column.cols;
      if (coarse) {
        const uint8_t* bc = view.column_bits.ptr<uint8_t>(y);
        const uint8_t* br = view.row_bits.ptr<uint8_t>(y);
        for (int x = 0; x < w; ++x) {
          if (c[x] < 0) continue;
          qc[x] = 1 << std::max(0, view.column_code_bits - bc[x]);
          qr[x] = 1 << std::max(0, view.row_code_bits - br[x]);
          hw[x] = 0.5f * static_cast<float>(qr[x] - 1);
        }
      }
      int start = 0;
      while (start < w) {
        if (c[start] < 0) {
          ++start;
          continue;
        }
        int end = start;  // inclusive end of the surface run
        while (end + 1 < w && c[end + 1] >= 0 &&
               std::abs(c[end + 1] - c[end]) <=
                   step + std::max(qc[end], qc[end + 1]) - 1 &&
               std::abs(rw[end + 1] - rw[end]) <=
                   step + std::max(qr[end], qr[end + 1]) - 1) {
          ++end;
        }
        for (int x = start; x <= end; ++x) {
          const int lo = std::max(start, x - k), hi = std::min(end, x + k);
          double n = 0, st = 0, stt = 0, su = 0, stu = 0, sv = 0, stv = 0;
          for (int t = lo; t <= hi; ++t) {
            const double dt = t - x;
            n += 1;
            st += dt;
            stt += dt * dt;
            su += c[t];
            stu += dt * c[t];
            sv += rw[t];
            stv += dt * rw[t];
          }
          u[x] = static_cast<float>(FitIntercept(n, st, stt, su, stu));
          v[x] = static_cast<float>(FitIntercept(n, st, stt, sv, stv));
        }
        start = end + 1;
      }
    }
  });
  return out;
}

absl::StatusOr<ViewDisparity> ComputeViewDisparity(
    const SubpixelCodes& left, const SubpixelCodes& right,
    const MatchOptions& options) {
  if (left.column.empty() || right.column.empty()) {
    return absl::InvalidArgumentError("view disparity: a view is not decoded");
  }
  if (left.column.size() != right.column.size()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "view disparity: left is %dx%d but right is %dx%d", left.column.cols,
        left.column.rows, right.column.cols, right.column.rows));
  }
  try {
    const int max_d =
        options.max_disparity > 0 ? options.max_disparity : left.column.cols;
    ViewDisparity out;
    out.left_matched = MatchScanlines(left, right, +1, options,
                                      options.min_disparity, max_d, &out.left);
    out.right_matched = MatchScanlines(
        right, left, -1, options, options.min_disparity, max_d, &out.right);
    const cv::Mat right_before = out.right.clone();
    out.right_rejected =
        CrossCheck(&out.right, out.left, -1, options.lr_tolerance);
    out.left_rejected =
        CrossCheck(&out.left, right_before, +1, options.lr_tolerance);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("view disparity: ", e.what()));
  }
}

absl::StatusOr<ProjectorMatrix> EstimateProjectorMatrix(
    const SubpixelCodes& left, const cv::Mat& left_disparity,
    const ProjectorFitOptions& options) {
  std::vector<Sample> all;
  for (int y = 0; y < left_disparity.rows; ++y) {
    const float* d = left_disparity.ptr<float>(y);
    const float* u = left.column.ptr<float>(y);
    const float* v = left.row.ptr<float>(y);
    for (int x = 0; x < left_disparity.cols; ++x) {
      if (std::isfinite(d[x]) && !std::isnan(u[x]) && !std::isnan(v[x])) {
        all.push_back(
            {static_cast<double>(x), static_cast<double>(y), d[x], u[x], v[x]});
      }
    }
  }
  if (all.size() < 12) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "projector matrix: only %d pixels have a view disparity and a code",
        all.size()));
  }
  std::vector<Sample> s;
  const size_t stride =
      std::max<size_t>(1, all.size() / std::max(options.max_samples, 12));
  for (size_t i = 0; i < all.size(); i += stride) s.push_back(all[i]);
  const int n = static_cast<int>(s.size());

  auto inliers_of = [&](const cv::Matx34d& p, double tol, std::vector<int>* idx,
                        std::vector<double>* w) {
    idx->clear();
    if (w != nullptr) w->assign(n, 1.0);
    for (int i = 0; i < n; ++i) {
      double depth = 1;
      if (Reprojection(p, s[i], &depth) < tol) {
        idx->push_back(i);
        if (w != nullptr) (*w)[i] = 1.0 / std::max(std::abs(depth), 1e-12);
      }
    }
  };

  cv::RNG rng(options.seed);
  cv::Matx34d best_p;
  size_t best_count = 0;
  std::vector<int> idx, pick(6);
  for (int it = 0; it < options.ransac_iterations; ++it) {
    for (int j = 0; j < 6; ++j) {
      bool unique;
      do {
        pick[j] = rng.uniform(0, n);
        unique = true;
        for (int k = 0; k < j; ++k) unique = unique && pick[k] != pick[j];
      } while (!unique);
    }
    cv::Matx34d p;
    if (!Dlt(s, pick, {}, &p)) continue;
    inliers_of(p, options.inlier_px, &idx, nullptr);
    if (idx.size() > best_count) {
      best_count = idx.size();
      best_p = p;
    }
  }
  if (best_count < 12) {
    return absl::FailedPreconditionError(
        "projector matrix: no consistent projection found (RANSAC)");
  }
  // Refinement: linear fit on the inliers, then reweighting by the
  // projective depth so that the algebraic error approximates the
  // reprojection error.
  std::vector<double> w;
  cv::Matx34d p = best_p;
  for (int round = 0; round < 4; ++round) {
    inliers_of(p, options.inlier_px, &idx, &w);
    cv::Matx34d refined;
    if (!Dlt(s, idx, round == 0 ? std::vector<double>() : w, &refined)) break;
    p = refined;
  }
  inliers_of(p, options.inlier_px, &idx, nullptr);
  if (idx.size() < 12) {
    return absl::FailedPreconditionError(
        "projector matrix: refinement lost the inliers");
  }
  double sum2 = 0;
  for (int i : idx) {
    const double e = Reprojection(p, s[i], nullptr);
    sum2 += e * e;
  }
  ProjectorMatrix out;
  out.left = p;
  // (x_r, y, d, 1) -> (x_r + d, y, d, 1) in the left view's disparity space.
  const cv::Matx44d to_left(1, 0, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1);
  out.right = p * to_left;
  out.samples = n;
  out.inliers = static_cast<int>(idx.size());
  out.rms_px = std::sqrt(sum2 / idx.size());
  return out;
}

cv::Mat IlluminationDisparity(const SubpixelCodes& codes, const cv::Matx34d& p,
                              double min_d, double max_d,
                              double max_residual_px) {
  cv::Mat out(codes.column.size(), CV_32FC1, cv::Scalar(kInf));
  cv::parallel_for_(cv::Range(0, out.rows), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      const float* u = codes.column.ptr<float>(y);
      const float* v = codes.row.ptr<float>(y);
      float* d = out.ptr<float>(y);
      for (int x = 0; x < out.cols; ++x) {
        if (std::isnan(u[x]) || std::isnan(v[x])) continue;
        // P (x, y, 0, 1) + d P(:, 2) ~ (u, v, 1): two linear equations in d.
        const cv::Vec3d q0 = p * cv::Vec4d(x, y, 0, 1);
        const cv::Vec3d e(p(0, 2), p(1, 2), p(2, 2));
        const double au = u[x] * e[2] - e[0], bu = u[x] * q0[2] - q0[0];
        const double av = v[x] * e[2] - e[1], bv = v[x] * q0[2] - q0[1];
        const double den = au * au + av * av;
        if (den <= 0) continue;
        const double disp = -(au * bu + av * bv) / den;
        if (!(disp >= min_d && disp <= max_d)) continue;
        const cv::Vec3d q = q0 + disp * e;
        if (std::abs(q[2]) < 1e-12) continue;
        const double err = std::hypot(q[0] / q[2] - u[x], q[1] / q[2] - v[x]);
        if (err <= max_residual_px) d[x] = static_cast<float>(disp);
      }
    }
  });
  return out;
}

}  // namespace hdrstereo::structured_light
