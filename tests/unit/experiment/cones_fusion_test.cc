// SPDX-License-Identifier: GPL-3.0-or-later
//
// The default fusion, its plane prior, photo-consistency choice and
// speckle filter included, on the one real stereo pair in ../shared/data,
// Middlebury 2003 Cones, scored against its structured-light truth
// (non-occluded pixels). Cones is one 8-bit exposure per view, linearised
// with gamma 2.2 and tone-mapped by each of the seven operators (as
// tests/unit/tonemap/cones_matching_test.cc does), so it cannot show what
// HDR gains; it checks that on a real, mostly textured scene with real
// noise none of the last steps makes the fused map worse, and that fusion
// beats the median of its inputs. Skips, saying why, when the folder is
// absent.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <map>
#include <vector>

#include "processing/eval/disparity_eval.h"
#include "processing/experiment/thesis_experiment.h"
#include "tests/support/middlebury2003.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::experiment {
namespace {

using ::hdrstereo::testing::LinearisedWithGamma22;
using ::hdrstereo::testing::Middlebury2003;

constexpr int kMaxDisparity = 59;  // Cones at quarter size

eval::RegionMetrics Scored(const cv::Mat& disparity, const Middlebury2003& m) {
  absl::StatusOr<eval::DisparityEvaluation> e =
      eval::EvaluateDisparity(disparity, m.truth, m.nonoccluded, cv::Mat(), {});
  EXPECT_TRUE(e.ok()) << e.status();
  return e.ok() ? e->nonoccluded : eval::RegionMetrics{};
}

TEST(ConesFusionTest, TheLastStepsDoNotHurtARealTexturedPair) {
  const std::filesystem::path dir = ::hdrstereo::testing::ConesDir();
  if (!std::filesystem::is_directory(dir)) {
    GTEST_SKIP() << dir << " is absent (../shared/data not checked out)";
  }
  ASSERT_OK_AND_ASSIGN(const Middlebury2003 m,
                       ::hdrstereo::testing::LoadMiddlebury2003(dir));
  ExperimentOptions options;
  const cv::Mat left = LinearisedWithGamma22(m.left),
                right = LinearisedWithGamma22(m.right);
  std::map<Method, StereoPair> pairs;
  for (Method method : ToneMappedMethods()) {
    ASSERT_OK_AND_ASSIGN(pairs[method],
                         ToneMapped(method, left, right, options));
  }
  ASSERT_OK_AND_ASSIGN(const auto candidates,
                       MatchAllMethods(pairs, kMaxDisparity, options));
  std::vector<const Candidate*> seven;
  double best_rmse = 1e9, best_bad1 = 100;
  for (Method method : ToneMappedMethods()) {
    seven.push_back(&candidates.at(method));
    const eval::RegionMetrics s = Scored(candidates.at(method).disparity, m);
    best_rmse = std::min(best_rmse, s.rmse);
    best_bad1 = std::min(best_bad1, s.bad_percent.at(1));
  }
  const FusionViews views{m.left, pairs.at(kFusionView).left,
                          pairs.at(kFusionView).right};
  ASSERT_OK_AND_ASSIGN(const fusion::FusionResult with,
                       FuseSome(seven, views, kMaxDisparity, options));
  ExperimentOptions no_planes = options;
  no_planes.robust_fusion.planes.enabled = false;
  ASSERT_OK_AND_ASSIGN(const fusion::FusionResult without,
                       FuseSome(seven, views, kMaxDisparity, no_planes));
  ExperimentOptions no_photo = options;
  no_photo.robust_fusion.photo.enabled = false;
  ASSERT_OK_AND_ASSIGN(const fusion::FusionResult unchecked,
                       FuseSome(seven, views, kMaxDisparity, no_photo));
  ExperimentOptions no_speckles = options;
  no_speckles.robust_fusion.speckles.enabled = false;
  ASSERT_OK_AND_ASSIGN(const fusion::FusionResult speckled,
                       FuseSome(seven, views, kMaxDisparity, no_speckles));
  std::vector<cv::Mat> maps;
  for (const Candidate* c : seven) maps.push_back(c->disparity);
  ASSERT_OK_AND_ASSIGN(const cv::Mat median,
                       fusion::FuseMedian(maps, kMaxDisparity));

  const eval::RegionMetrics p = Scored(with.disparity, m);
  const eval::RegionMetrics n = Scored(without.disparity, m);
  const eval::RegionMetrics u = Scored(unchecked.disparity, m);
  const eval::RegionMetrics md = Scored(median, m);
  const eval::RegionMetrics sp = Scored(speckled.disparity, m);
  std::cout << "Cones: fused " << p.rmse << " / " << p.bad_percent.at(1)
            << " %, without planes " << n.rmse << " / " << n.bad_percent.at(1)
            << " %, without the photo-consistency choice " << u.rmse << " / "
            << u.bad_percent.at(1) << " %, without the speckle filter "
            << sp.rmse << " / " << sp.bad_percent.at(1) << " %, median "
            << md.rmse << " / " << md.bad_percent.at(1) << " %, best candidate "
            << best_rmse << " / " << best_bad1 << " %\n";
  // Measured 2026-12-06 (RMSE px / bad-1px %): fused 1.086 / 2.38,
  // without planes 1.086 / 2.38, without the photo-consistency choice
  // 1.137 / 2.45, without the speckle filter 1.138 / 2.44, median 1.151 /
  // 2.57, best candidate by each measure 1.131 / 2.32 (Reinhard). Cones is
  // textured almost everywhere, so the planes must leave it as it was
  // (bounds: a tenth of a point, 0.02 px); neither of the last two steps
  // may make it worse; fused beats the median by both measures and every
  // candidate by RMSE.
  EXPECT_LE(p.bad_percent.at(1), n.bad_percent.at(1) + 0.1);
  EXPECT_LE(p.rmse, n.rmse + 0.02);
  EXPECT_LE(p.rmse, u.rmse);
  EXPECT_LE(p.bad_percent.at(1), u.bad_percent.at(1));
  EXPECT_LE(p.rmse, sp.rmse);
  EXPECT_LE(p.bad_percent.at(1), sp.bad_percent.at(1));
  EXPECT_LE(p.rmse, md.rmse);
  EXPECT_LE(p.bad_percent.at(1), md.bad_percent.at(1));
  EXPECT_LE(p.rmse, best_rmse);
  // The rule that only values two candidates share are proposed keeps the
  // choice from hurting: lone values win on cost where they are wrong
  // (measured 1.135 / 2.59 % with min_agreeing 1).
  ExperimentOptions lone = options;
  lone.robust_fusion.photo.min_agreeing = 1;
  ASSERT_OK_AND_ASSIGN(const fusion::FusionResult l,
                       FuseSome(seven, views, kMaxDisparity, lone));
  EXPECT_GT(Scored(l.disparity, m).rmse, p.rmse + 0.03);
  // The texture rule is what keeps them: with every segment counted as
  // untextured, planes cross Cones' depth edges (measured 1.44 / 8.36 %).
  ExperimentOptions everywhere = options;
  everywhere.robust_fusion.planes.max_texture = 255;
  ASSERT_OK_AND_ASSIGN(const fusion::FusionResult e,
                       FuseSome(seven, views, kMaxDisparity, everywhere));
  EXPECT_GT(Scored(e.disparity, m).bad_percent.at(1), p.bad_percent.at(1) + 2);
}

}  // namespace
}  // namespace hdrstereo::experiment
