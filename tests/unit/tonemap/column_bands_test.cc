// SPDX-License-Identifier: GPL-3.0-or-later
//
// A tone-mapped pair must show the same surface point alike in both views,
// wherever it lies in the image and at any image size (issue 37, section 3:
// Fattal's right view had a dark band along its right edge at 1200 px that
// its left view lacked). On radiance merged from a scene's simulated
// exposure stacks, each left-view pixel is compared with the right view's
// pixel of the same surface point (through the exact disparity), in ten
// column bands of the right view: the mean absolute difference per band,
// in grey levels, at the thesis' 320 px and at 1200 px.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/experiment/thesis_table.h"
#include "processing/tonemap/tonemap.h"
#include "tests/support/status_matchers.h"
#include "tests/support/thesis_scene.h"

namespace hdrstereo::tonemap {
namespace {

constexpr int kBands = 10;

// Both views' radiance merged from the scene's simulated exposure stacks,
// as the pipeline and the thesis table merge them (sensor noise included).
struct Merged {
  experiment::TableInput scene;
  cv::Mat left, right;
};

absl::StatusOr<Merged> Merge(const std::string& name, int width) {
  Merged m;
  ASSIGN_OR_RETURN(m.scene, testing::RenderThesisScene(name, width));
  const experiment::ExperimentOptions o;
  ASSIGN_OR_RETURN(const hdr::CameraResponse response,
                   experiment::ResponseOf(m.scene.left, o));
  ASSIGN_OR_RETURN(m.left, experiment::RadianceOf(m.scene.left, response, o));
  ASSIGN_OR_RETURN(m.right, experiment::RadianceOf(m.scene.right, response, o));
  return m;
}

// Per column band of the right view: the mean of |right - left| (grey
// levels of the luma) over the left view's non-occluded pixels, each
// compared with the right view's pixel at x - disparity.
std::vector<double> BandDifferences(const experiment::TableInput& scene,
                                    const cv::Mat& left, const cv::Mat& right) {
  cv::Mat l, r;
  cv::cvtColor(left, l, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right, r, cv::COLOR_BGR2GRAY);
  std::vector<double> sum(kBands, 0), count(kBands, 0);
  for (int y = 0; y < l.rows; ++y) {
    for (int x = 0; x < l.cols; ++x) {
      const float d = scene.truth.at<float>(y, x);
      if (!scene.nonoccluded.at<uchar>(y, x) || !std::isfinite(d)) continue;
      const float xr = static_cast<float>(x) - d;
      const int x0 = static_cast<int>(std::floor(xr));
      if (x0 < 0 || x0 + 1 >= r.cols) continue;
      const float f = xr - static_cast<float>(x0);
      const double seen_right =
          r.at<uchar>(y, x0) * (1 - f) + r.at<uchar>(y, x0 + 1) * f;
      const int band = x0 * kBands / r.cols;
      sum[band] += std::abs(seen_right - l.at<uchar>(y, x));
      count[band] += 1;
    }
  }
  std::vector<double> out(kBands, 0);
  for (int b = 0; b < kBands; ++b) {
    out[b] = count[b] > 0 ? sum[b] / count[b] : 0;
  }
  return out;
}

double Largest(const std::vector<double>& v) {
  return *std::max_element(v.begin(), v.end());
}

absl::StatusOr<std::vector<double>> Bands(const Merged& m, Operator op,
                                          const Params& params) {
  ASSIGN_OR_RETURN(const auto pair, ToneMapPair(m.left, m.right, op, params));
  return BandDifferences(m.scene, pair.first, pair.second);
}

void Print(const std::string& what, const std::vector<double>& bands) {
  std::cout << absl::StrFormat("%-36s", what);
  for (double b : bands) std::cout << absl::StrFormat(" %4.1f", b);
  std::cout << "\n";
}

// At 1200 px no band of any operator differs between the views by more
// than 1 grey level beyond the worst band at 320 px (the thesis' size).
// Measured on lab-lamp, largest band at 320 / 1200 px: Reinhard 0.9 / 0.6,
// Durand 2.3 / 1.6, Fattal 1.9 / 2.3, Drago 0.8 / 0.5, He 1.0 / 1.1, Gastal
// 5.2 / 1.8, Farbman 3.8 / 2.1; on textured every operator's bands are
// smaller at 1200 px (its fine texture is resampled at 320 px).
TEST(ColumnBandsTest, NoOperatorsViewsDriftApartWithSize) {
  for (const char* scene : {"lab-lamp", "textured"}) {
    ASSERT_OK_AND_ASSIGN(const Merged small, Merge(scene, 320));
    ASSERT_OK_AND_ASSIGN(const Merged large, Merge(scene, 1200));
    for (Operator op : AllOperators()) {
      SCOPED_TRACE(absl::StrCat(scene, " ", OperatorName(op)));
      ASSERT_OK_AND_ASSIGN(const std::vector<double> at320,
                           Bands(small, op, Params()));
      ASSERT_OK_AND_ASSIGN(const std::vector<double> at1200,
                           Bands(large, op, Params()));
      Print(absl::StrCat(scene, " 320 px ", OperatorName(op)), at320);
      Print(absl::StrCat(scene, " 1200 px ", OperatorName(op)), at1200);
      EXPECT_LE(Largest(at1200), Largest(at320) + 1.0);
    }
  }
}

// The check sees the artifact it is for: Fattal solved at 1200 px itself
// (solve_width 0, the thesis' operator as is) darkens the right view's
// rightmost bands (measured 3.4 and 4.6 grey levels on lab-lamp, 1.9 at
// most at 320 px).
TEST(ColumnBandsTest, FattalSolvedAtFullSizeShowsTheRightEdgeBand) {
  ASSERT_OK_AND_ASSIGN(const Merged small, Merge("lab-lamp", 320));
  ASSERT_OK_AND_ASSIGN(const Merged large, Merge("lab-lamp", 1200));
  Params full_size;
  full_size.fattal.solve_width = 0;
  ASSERT_OK_AND_ASSIGN(const std::vector<double> at320,
                       Bands(small, Operator::kFattal, full_size));
  ASSERT_OK_AND_ASSIGN(const std::vector<double> at1200,
                       Bands(large, Operator::kFattal, full_size));
  Print("lab-lamp 1200 px fattal at full size", at1200);
  EXPECT_GT(at1200.back(), Largest(at320) + 1.0);
}

}  // namespace
}  // namespace hdrstereo::tonemap
