// SPDX-License-Identifier: GPL-3.0-or-later
//
// A plain double-precision guided filter (He et al., colour guide, per-pixel
// 3x3 solve) for tests: with a colour guide and small eps, OpenCV's float
// ximgproc::guidedFilter is off by more than the differences that matter.
#ifndef HDRSTEREO_TESTS_SUPPORT_REFERENCE_GUIDED_FILTER_H_
#define HDRSTEREO_TESTS_SUPPORT_REFERENCE_GUIDED_FILTER_H_

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace hdrstereo::testing {

inline cv::Mat DoubleBox(const cv::Mat& m, int r) {
  cv::Mat o;
  cv::boxFilter(m, o, CV_64F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1),
                true, cv::BORDER_REFLECT);
  return o;
}

// He et al.'s colour-guide filter in double precision (CV_64FC1 result):
// the reference that our float filters are checked against.
inline cv::Mat DoubleColourGuided(const cv::Mat& guide, const cv::Mat& src,
                                  int r, double eps) {
  cv::Mat gd, sd;
  guide.convertTo(gd, CV_64F);
  src.convertTo(sd, CV_64F);
  std::vector<cv::Mat> g;
  cv::split(gd, g);
  const cv::Mat mp = DoubleBox(sd, r);
  cv::Mat mi[3], cov[3], var[3][3], a[3];
  for (int c = 0; c < 3; ++c) {
    mi[c] = DoubleBox(g[c], r);
    cov[c] = DoubleBox(g[c].mul(sd), r) - mi[c].mul(mp);
    a[c].create(guide.size(), CV_64F);
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      var[i][j] = DoubleBox(g[i].mul(g[j]), r) - mi[i].mul(mi[j]);
    }
  }
  for (int y = 0; y < guide.rows; ++y) {
    for (int x = 0; x < guide.cols; ++x) {
      cv::Matx33d s;
      cv::Vec3d c;
      for (int i = 0; i < 3; ++i) {
        c[i] = cov[i].at<double>(y, x);
        for (int j = 0; j < 3; ++j) {
          s(i, j) = var[i][j].at<double>(y, x) + (i == j ? eps : 0.0);
        }
      }
      const cv::Vec3d av = s.solve(c, cv::DECOMP_LU);
      for (int k = 0; k < 3; ++k) a[k].at<double>(y, x) = av[k];
    }
  }
  cv::Mat b = mp.clone();
  for (int c = 0; c < 3; ++c) b -= a[c].mul(mi[c]);
  cv::Mat q = DoubleBox(b, r);
  for (int c = 0; c < 3; ++c) q += DoubleBox(a[c], r).mul(g[c]);
  return q;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_REFERENCE_GUIDED_FILTER_H_
