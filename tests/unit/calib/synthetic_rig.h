// SPDX-License-Identifier: GPL-3.0-or-later
//
// Synthetic chessboard views of a stereo rig with a known camera: the board
// plane is mapped into each view by its exact homography K [r1 r2 t],
// rendered at 2x and area-downsampled. Shared by calibration and tool tests.
#ifndef HDRSTEREO_TESTS_UNIT_CALIB_SYNTHETIC_RIG_H_
#define HDRSTEREO_TESTS_UNIT_CALIB_SYNTHETIC_RIG_H_

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace hdrstereo::testing {

inline constexpr int kWidth = 400;
inline constexpr int kHeight = 300;
inline const cv::Size kCorners(7, 5);
inline constexpr double kSquare = 0.03;  // m
inline constexpr int kTexelsPerSquare = 40;

inline cv::Matx33d TrueK() {
  return cv::Matx33d(450, 0, 199.5, 0, 450, 149.5, 0, 0, 1);
}

// Board texture: (corners + 1) squares plus a one-square white margin.
inline cv::Mat BoardTexture() {
  const int sq = kTexelsPerSquare;
  const int cols = kCorners.width + 1, rows = kCorners.height + 1;
  cv::Mat t((rows + 2) * sq, (cols + 2) * sq, CV_8U, cv::Scalar(255));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 == 0) {
        t(cv::Rect((c + 1) * sq, (r + 1) * sq, sq, sq)).setTo(20);
      }
    }
  }
  return t;
}

// Renders the board with pose (R, t) in the camera frame. Board point
// (X, Y, 0) in metres has its first inner corner at the origin.
inline cv::Mat Render(const cv::Matx33d& rot, const cv::Vec3d& t) {
  static const cv::Mat texture = BoardTexture();
  const double m_per_texel = kSquare / kTexelsPerSquare;
  // Texel (u, v) -> board metres: the first inner corner is at texel
  // (2 sq, 2 sq) (margin + one square); texel centres at +0.5.
  const cv::Matx33d texel_to_board(
      m_per_texel, 0, -(2 * kTexelsPerSquare - 0.5) * m_per_texel, 0,
      m_per_texel, -(2 * kTexelsPerSquare - 0.5) * m_per_texel, 0, 0, 1);
  // Render at 2x: x2 = 2x + 0.5.
  const cv::Matx33d k = TrueK();
  const cv::Matx33d k2(2 * k(0, 0), 0, 2 * k(0, 2) + 0.5, 0, 2 * k(1, 1),
                       2 * k(1, 2) + 0.5, 0, 0, 1);
  const cv::Matx33d rt(rot(0, 0), rot(0, 1), t[0], rot(1, 0), rot(1, 1), t[1],
                       rot(2, 0), rot(2, 1), t[2]);
  const cv::Matx33d h = k2 * rt * texel_to_board;
  cv::Mat big;
  cv::warpPerspective(texture, big, cv::Mat(h),
                      cv::Size(2 * kWidth, 2 * kHeight), cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(128));
  cv::Mat out;
  cv::resize(big, out, cv::Size(kWidth, kHeight), 0, 0, cv::INTER_AREA);
  return out;
}

inline cv::Matx33d Rotation(double rx, double ry, double rz) {
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(rx, ry, rz), r);
  return r;
}

struct Rig {
  cv::Matx33d rot;  // right = rot * left + trans
  cv::Vec3d trans;
};

struct Views {
  std::vector<cv::Mat> left, right;
  std::vector<std::string> left_names, right_names;
};

// Board poses in the left camera frame; the board centre sits ~0.6-0.75 m
// in front, tilted up to ~0.45 rad.
inline Views RenderViews(const Rig& rig) {
  const double tilts[][3] = {{0.0, 0.0, 0.0},    {0.35, 0.0, 0.05},
                             {-0.35, 0.1, 0.0},  {0.0, 0.4, -0.05},
                             {0.1, -0.4, 0.1},   {0.3, 0.3, 0.0},
                             {-0.3, -0.3, 0.05}, {0.2, -0.1, -0.1},
                             {-0.15, 0.45, 0.0}, {0.4, -0.2, 0.08}};
  Views v;
  int i = 0;
  for (const auto& tilt : tilts) {
    const cv::Matx33d r = Rotation(tilt[0], tilt[1], tilt[2]);
    // Put the board centre (3 x 2 squares from the first corner) in front,
    // between the two cameras.
    const cv::Vec3d centre_board(3 * kSquare, 2 * kSquare, 0);
    const cv::Vec3d where(0.02 * ((i % 3) - 1) + 0.04,
                          0.015 * ((i % 2) * 2 - 1), 0.62 + 0.015 * i);
    const cv::Vec3d t = where - r * centre_board;
    v.left.push_back(Render(r, t));
    v.right.push_back(Render(rig.rot * r, rig.rot * t + rig.trans));
    v.left_names.push_back("left_" + std::to_string(i) + ".png");
    v.right_names.push_back("right_" + std::to_string(i) + ".png");
    ++i;
  }
  return v;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_UNIT_CALIB_SYNTHETIC_RIG_H_
