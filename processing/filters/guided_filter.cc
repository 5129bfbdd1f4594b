// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/guided_filter.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/filters/mat_checks.h"

namespace hdrstereo::filters {
namespace {

// Runs fn(y) for every row, rows split over OpenCV's thread pool.
template <typename Fn>
void ForRows(int rows, const Fn& fn) {
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) fn(y);
  });
}

// Element-wise product of two CV_32FC1 mats of equal size.
void MulInto(const cv::Mat& a, const cv::Mat& b, cv::Mat& out) {
  out.create(a.size(), CV_32FC1);
  ForRows(a.rows, [&](int y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    float* po = out.ptr<float>(y);
    for (int x = 0; x < a.cols; ++x) po[x] = pa[x] * pb[x];
  });
}

cv::Mat Mul(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat out;
  MulInto(a, b, out);
  return out;
}

}  // namespace

void GuidedFilter::BoxInto(const cv::Mat& m, cv::Mat& out) const {
  cv::boxFilter(m, out, CV_32F,
                cv::Size(2 * work_radius_ + 1, 2 * work_radius_ + 1),
                cv::Point(-1, -1), /*normalize=*/true, cv::BORDER_REFLECT);
}

cv::Mat GuidedFilter::Box(const cv::Mat& m) const {
  cv::Mat out;
  cv::boxFilter(m, out, CV_32F,
                cv::Size(2 * work_radius_ + 1, 2 * work_radius_ + 1),
                cv::Point(-1, -1), /*normalize=*/true, cv::BORDER_REFLECT);
  return out;
}

absl::StatusOr<GuidedFilter> GuidedFilter::Create(
    const cv::Mat& guide, const GuidedFilterOptions& options) {
  RETURN_IF_ERROR(
      CheckImage(guide, "guided filter guide", /*float_only=*/false, {1, 3}));
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("guided filter: ", s.message()));
  }
  if (options.subsample > 1 && (guide.cols / options.subsample < 2 ||
                                guide.rows / options.subsample < 2)) {
    return absl::InvalidArgumentError(
        "guided filter subsample too large for the guide size");
  }
  GuidedFilter f;
  f.options_ = options;
  try {
    f.Init(ToFloat(guide));
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("guided filter: ", e.what()));
  }
  return f;
}

void GuidedFilter::Init(const cv::Mat& guide_float) {
  cv::split(guide_float, full_guide_);
  const int s = options_.subsample;
  if (s == 1) {
    guide_ = full_guide_;
    work_radius_ = options_.radius;
  } else {
    const cv::Size low(guide_float.cols / s, guide_float.rows / s);
    guide_.resize(full_guide_.size());
    for (size_t c = 0; c < full_guide_.size(); ++c) {
      cv::resize(full_guide_[c], guide_[c], low, 0, 0, cv::INTER_AREA);
    }
    work_radius_ = std::max(1, static_cast<int>(std::lround(
                                   static_cast<double>(options_.radius) / s)));
  }
  mean_guide_.clear();
  for (const cv::Mat& g : guide_) mean_guide_.push_back(Box(g));
  const float eps = static_cast<float>(options_.eps);
  const cv::Size sz = guide_[0].size();
  if (guide_.size() == 1) {
    cv::Mat corr = Box(Mul(guide_[0], guide_[0]));
    cv::Mat inv(sz, CV_32FC1);
    ForRows(sz.height, [&](int y) {
      const float* m = mean_guide_[0].ptr<float>(y);
      const float* c = corr.ptr<float>(y);
      float* o = inv.ptr<float>(y);
      for (int x = 0; x < sz.width; ++x) {
        o[x] = 1.0f / (c[x] - m[x] * m[x] + eps);
      }
    });
    inv_ = {inv};
    return;
  }
  // Colour guide: covariance matrix per pixel, inverted in closed form.
  const int pairs[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
  cv::Mat var[6];
  for (int k = 0; k < 6; ++k) {
    var[k] = Box(Mul(guide_[pairs[k][0]], guide_[pairs[k][1]]));
  }
  inv_.assign(6, cv::Mat());
  for (cv::Mat& m : inv_) m.create(sz, CV_32FC1);
  ForRows(sz.height, [&](int y) {
    const float* m[3] = {mean_guide_[0].ptr<float>(y),
                         mean_guide_[1].ptr<float>(y),
                         mean_guide_[2].ptr<float>(y)};
    const float* v[6];
    float* o[6];
    for (int k = 0; k < 6; ++k) {
      v[k] = var[k].ptr<float>(y);
      o[k] = inv_[k].ptr<float>(y);
    }
    InvertGuideCovarianceRow(m, v, eps, sz.width, o);
  });
}

void GuidedFilter::FilterPlane(const cv::Mat& src_full, cv::Mat& dst,
                               GuidedFilterWorkspace* workspace) const {
  GuidedFilterWorkspace local;
  GuidedFilterWorkspace& ws = workspace != nullptr ? *workspace : local;
  cv::Mat src = src_full;
  if (options_.subsample > 1) {
    cv::resize(src_full, ws.low_src, guide_[0].size(), 0, 0, cv::INTER_AREA);
    src = ws.low_src;
  }
  const cv::Size sz = src.size();
  BoxInto(src, ws.mean_p);
  const cv::Mat& mean_p = ws.mean_p;
  cv::Mat* a_b = ws.ab;  // a (1 or 3 planes) then b
  const int nc = static_cast<int>(guide_.size());
  if (nc == 1) {
    MulInto(guide_[0], src, ws.prod);
    BoxInto(ws.prod, ws.mean_ip[0]);
    const cv::Mat& mean_ip = ws.mean_ip[0];
    a_b[0].create(sz, CV_32FC1);
    a_b[1].create(sz, CV_32FC1);
    ForRows(sz.height, [&](int y) {
      const float* mi = mean_guide_[0].ptr<float>(y);
      const float* mp = mean_p.ptr<float>(y);
      const float* mip = mean_ip.ptr<float>(y);
      const float* inv = inv_[0].ptr<float>(y);
      float* a = a_b[0].ptr<float>(y);
      float* b = a_b[1].ptr<float>(y);
      for (int x = 0; x < sz.width; ++x) {
        a[x] = (mip[x] - mi[x] * mp[x]) * inv[x];
        b[x] = mp[x] - a[x] * mi[x];
      }
    });
  } else {
    const cv::Mat* mean_ip = ws.mean_ip;
    for (int c = 0; c < 3; ++c) {
      MulInto(guide_[c], src, ws.prod);
      BoxInto(ws.prod, ws.mean_ip[c]);
    }
    for (int k = 0; k < 4; ++k) a_b[k].create(sz, CV_32FC1);
    ForRows(sz.height, [&](int y) {
      const float* mi[3];
      const float* mip[3];
      const float* inv[6];
      float* a[3];
      for (int c = 0; c < 3; ++c) {
        mi[c] = mean_guide_[c].ptr<float>(y);
        mip[c] = mean_ip[c].ptr<float>(y);
        a[c] = a_b[c].ptr<float>(y);
      }
      for (int k = 0; k < 6; ++k) inv[k] = inv_[k].ptr<float>(y);
      const float* mp = mean_p.ptr<float>(y);
      float* b = a_b[3].ptr<float>(y);
      for (int x = 0; x < sz.width; ++x) {
        const float c0 = mip[0][x] - mi[0][x] * mp[x];
        const float c1 = mip[1][x] - mi[1][x] * mp[x];
        const float c2 = mip[2][x] - mi[2][x] * mp[x];
        const float a0 = inv[0][x] * c0 + inv[1][x] * c1 + inv[2][x] * c2;
        const float a1 = inv[1][x] * c0 + inv[3][x] * c1 + inv[4][x] * c2;
        const float a2 = inv[2][x] * c0 + inv[4][x] * c1 + inv[5][x] * c2;
        a[0][x] = a0;
        a[1][x] = a1;
        a[2][x] = a2;
        b[x] = mp[x] - a0 * mi[0][x] - a1 * mi[1][x] - a2 * mi[2][x];
      }
    });
  }
  const cv::Mat* mean_ab = ws.mean_ab;
  for (int k = 0; k <= nc; ++k) {
    BoxInto(a_b[k], ws.mean_ab[k]);
    if (options_.subsample > 1) {
      cv::resize(ws.mean_ab[k], ws.up[k], src_full.size(), 0, 0,
                 cv::INTER_LINEAR);
      mean_ab = ws.up;
    }
  }
  const cv::Size full = src_full.size();
  dst.create(full, CV_32FC1);
  ForRows(full.height, [&](int y) {
    float* q = dst.ptr<float>(y);
    const float* b = mean_ab[nc].ptr<float>(y);
    const float* a0 = mean_ab[0].ptr<float>(y);
    const float* i0 = full_guide_[0].ptr<float>(y);
    if (nc == 1) {
      for (int x = 0; x < full.width; ++x) q[x] = a0[x] * i0[x] + b[x];
    } else {
      const float* a1 = mean_ab[1].ptr<float>(y);
      const float* a2 = mean_ab[2].ptr<float>(y);
      const float* i1 = full_guide_[1].ptr<float>(y);
      const float* i2 = full_guide_[2].ptr<float>(y);
      for (int x = 0; x < full.width; ++x) {
        q[x] = a0[x] * i0[x] + a1[x] * i1[x] + a2[x] * i2[x] + b[x];
      }
    }
  });
}

absl::StatusOr<cv::Mat> GuidedFilter::Filter(const cv::Mat& src) const {
  RETURN_IF_ERROR(
      CheckImage(src, "guided filter input", /*float_only=*/false, {}));
  if (src.size() != size()) {
    return absl::InvalidArgumentError(
        "guided filter input and guide differ in size");
  }
  try {
    const cv::Mat srcf = ToFloat(src);
    if (srcf.channels() == 1) {
      cv::Mat out;
      FilterPlane(srcf, out);
      return out;
    }
    std::vector<cv::Mat> planes;
    cv::split(srcf, planes);
    for (cv::Mat& p : planes) {
      cv::Mat q;
      FilterPlane(p, q);
      p = q;
    }
    cv::Mat out;
    cv::merge(planes, out);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("guided filter: ", e.what()));
  }
}

absl::StatusOr<cv::Mat> ApplyGuidedFilter(const cv::Mat& guide,
                                          const cv::Mat& src,
                                          const GuidedFilterOptions& options) {
  ASSIGN_OR_RETURN(GuidedFilter f, GuidedFilter::Create(guide, options));
  return f.Filter(src);
}

void InvertGuideCovarianceRow(const float* const mean[3],
                              const float* const corr[6], float eps, int width,
                              float* const inv[6]) {
  const float* m0 = mean[0];
  const float* m1 = mean[1];
  const float* m2 = mean[2];
  for (int x = 0; x < width; ++x) {
    const float rr = corr[0][x] - m0[x] * m0[x] + eps;
    const float rg = corr[1][x] - m0[x] * m1[x];
    const float rb = corr[2][x] - m0[x] * m2[x];
    const float gg = corr[3][x] - m1[x] * m1[x] + eps;
    const float gb = corr[4][x] - m1[x] * m2[x];
    const float bb = corr[5][x] - m2[x] * m2[x] + eps;
    const float i_rr = gg * bb - gb * gb;
    const float i_rg = gb * rb - rg * bb;
    const float i_rb = rg * gb - gg * rb;
    const float i_gg = rr * bb - rb * rb;
    const float i_gb = rb * rg - rr * gb;
    const float i_bb = rr * gg - rg * rg;
    const float inv_det = 1.0f / (rr * i_rr + rg * i_rg + rb * i_rb);
    inv[0][x] = i_rr * inv_det;
    inv[1][x] = i_rg * inv_det;
    inv[2][x] = i_rb * inv_det;
    inv[3][x] = i_gg * inv_det;
    inv[4][x] = i_gb * inv_det;
    inv[5][x] = i_bb * inv_det;
  }
}

}  // namespace hdrstereo::filters
