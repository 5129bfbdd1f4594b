// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/ground_truth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>

#include "processing/io/hdr_formats.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/disparity.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/structured_light/sim_capture.h"

namespace hdrstereo::structured_light {
namespace {

struct Score {
  int evaluated = 0;
  int covered = 0;
  int within_half = 0;
  double sum2 = 0;
  int all_valid = 0;
  int all_within_one = 0;
  int unlit_valid = 0;
  int lamp_valid = 0;
  int lamp_wrong = 0;
  double coverage() const {
    return evaluated ? static_cast<double>(covered) / evaluated : 0;
  }
  double within() const {
    return covered ? static_cast<double>(within_half) / covered : 0;
  }
  double rmse() const { return covered ? std::sqrt(sum2 / covered) : 0; }
};

// Scores `disp` against the sim truth of one view. Evaluated: pixels visible
// in both views (sim non-occlusion) and lit by the projector with >= 10% of
// their radiance (see sim_capture.h), lamp excluded.
Score Evaluate(const cv::Mat& disp, const testing::SimViewTruth& t) {
  Score s;
  for (int y = 0; y < disp.rows; ++y) {
    for (int x = 0; x < disp.cols; ++x) {
      const float d = disp.at<float>(y, x);
      const float truth = t.disparity.at<float>(y, x);
      const bool valid = std::isfinite(d);
      if (t.emitter.at<uint8_t>(y, x)) {
        s.lamp_valid += valid;
        s.lamp_wrong += valid && std::abs(d - truth) > 0.5;
        continue;
      }
      if (!t.lit.at<uint8_t>(y, x)) {
        s.unlit_valid += valid;
        continue;
      }
      if (valid && std::isfinite(truth)) {
        ++s.all_valid;
        s.all_within_one += std::abs(d - truth) <= 1.0;
      }
      if (!t.nonoccluded.at<uint8_t>(y, x) ||
          !t.strongly_lit.at<uint8_t>(y, x) || !std::isfinite(truth)) {
        continue;
      }
      ++s.evaluated;
      if (!valid) continue;
      ++s.covered;
      const double e = d - truth;
      s.sum2 += e * e;
      s.within_half += std::abs(e) <= 0.5;
    }
  }
  return s;
}

class SimGroundTruthTest : public ::testing::TestWithParam<const char*> {};

TEST_P(SimGroundTruthTest, MeetsAccuracyTargetsAgainstSimTruth) {
  const testing::SimCapture& capture = testing::CachedSimCapture(GetParam());
  absl::StatusOr<DecodedView> left = Decode(capture.views[0]);
  absl::StatusOr<DecodedView> right = Decode(capture.views[1]);
  ASSERT_TRUE(left.ok() && right.ok());

  // View disparities alone (no illumination, no filling).
  GroundTruthOptions view_only;
  view_only.use_illumination = false;
  view_only.max_hole_area = 0;
  absl::StatusOr<GroundTruth> vo = ComputeGroundTruth(*left, *right, view_only);
  ASSERT_TRUE(vo.ok()) << vo.status();
  const Score sv = Evaluate(vo->disp0, capture.truth[0]);
  std::cout << GetParam() << " view disparity only (left): coverage "
            << sv.coverage() * 100 << "%, within 0.5 px " << sv.within() * 100
            << "%, RMSE " << sv.rmse() << " px\n";

  absl::StatusOr<GroundTruth> gt = ComputeGroundTruth(*left, *right);
  ASSERT_TRUE(gt.ok()) << gt.status();
  std::cout << StatsJson(gt->stats);
  for (const std::string& w : gt->warnings)
    std::cout << "warning: " << w << "\n";
  ASSERT_TRUE(gt->stats.projector_fitted);
  EXPECT_LT(gt->stats.projector_rms_px, 0.5);
  // Illumination disparities fill pixels only one camera matches (mostly
  // occluded in the other view), and the projector shadows are reported as
  // unlit regions, not filled.
  EXPECT_GT(gt->stats.view[0].illumination_only, 0);
  EXPECT_GT(gt->stats.view[0].unlit_regions, 0);

  const cv::Mat* maps[2] = {&gt->disp0, &gt->disp1};
  for (int v = 0; v < 2; ++v) {
    const Score s = Evaluate(*maps[v], capture.truth[v]);
    std::cout << GetParam() << (v == 0 ? " left" : " right") << ": evaluated "
              << s.evaluated << ", coverage " << s.coverage() * 100
              << "%, within 0.5 px " << s.within() * 100 << "%, RMSE "
              << s.rmse() << " px; all valid lit pixels (incl. "
              << "occluded): " << s.all_valid << ", within 1 px "
              << 100.0 * s.all_within_one / std::max(1, s.all_valid)
              << "%; unlit valid " << s.unlit_valid << "; lamp valid "
              << s.lamp_valid << " wrong " << s.lamp_wrong << "\n";
    // Targets: coverage >= 98%, >= 99% within 0.5 px,
    // RMSE <= 0.25 px; nothing in projector shadow; the lamp invalid or
    // right; values filled in occluded areas right within 1 px (>= 99%).
    EXPECT_GE(s.coverage(), 0.98);
    EXPECT_GE(s.within(), 0.99);
    EXPECT_LE(s.rmse(), 0.25);
    EXPECT_EQ(s.unlit_valid, 0);
    EXPECT_EQ(s.lamp_wrong, 0);
    EXPECT_GE(s.all_within_one, 0.99 * s.all_valid);
  }
  // Occlusion mask: pixels the sim calls non-occluded are mostly 255.
  int nocc = 0, agree = 0;
  for (int y = 0; y < gt->mask0nocc.rows; ++y) {
    for (int x = 0; x < gt->mask0nocc.cols; ++x) {
      if (gt->mask0nocc.at<uint8_t>(y, x) == 0) continue;
      ++nocc;
      agree += (gt->mask0nocc.at<uint8_t>(y, x) == 255) ==
               (capture.truth[0].nonoccluded.at<uint8_t>(y, x) != 0);
    }
  }
  std::cout << GetParam() << " mask0nocc agrees with sim on "
            << 100.0 * agree / std::max(1, nocc) << "% of valid pixels\n";
  EXPECT_GE(agree, 0.98 * nocc);
}

// The ground truth must be more accurate than the matchers it
// scores. The matchers get their best case: the projector dark, the
// mid-exposure LDR pair, and the exact noise-free radiance for HDR. All are
// scored on the same pixels as above.
TEST_P(SimGroundTruthTest, MoreAccurateThanCostVolumeStereoOnTheSameScene) {
  const testing::SimCapture& capture = testing::CachedSimCapture(GetParam());
  absl::StatusOr<DecodedView> left = Decode(capture.views[0]);
  absl::StatusOr<DecodedView> right = Decode(capture.views[1]);
  ASSERT_TRUE(left.ok() && right.ok());
  absl::StatusOr<GroundTruth> gt = ComputeGroundTruth(*left, *right);
  ASSERT_TRUE(gt.ok()) << gt.status();
  const Score sl = Evaluate(gt->disp0, capture.truth[0]);

  sim::SimWorld world(capture.scene);
  world.BlankProjector();
  cv::Mat ldr[2], hdr[2];
  for (int v = 0; v < 2; ++v) {
    world.SetStagePosition(v * capture.baseline_mm);
    ldr[v] = world.RenderExposure({1.0 / 125, 100}, 8);
    hdr[v] = world.RenderRadiance().radiance;
  }
  double max_disparity = 0;
  cv::Mat finite = capture.truth[0].disparity.clone();
  cv::patchNaNs(finite, 0);
  finite.setTo(0, finite == std::numeric_limits<float>::infinity());
  cv::minMaxLoc(finite, nullptr, &max_disparity);
  stereo::StereoOptions ldr_options;
  ldr_options.max_disparity = static_cast<int>(std::ceil(max_disparity)) + 2;
  stereo::StereoOptions hdr_options = stereo::StereoOptions::Hdr();
  hdr_options.max_disparity = ldr_options.max_disparity;
  absl::StatusOr<stereo::StereoResult> ldr_result =
      stereo::ComputeDisparity(ldr[0], ldr[1], ldr_options);
  absl::StatusOr<stereo::StereoResult> hdr_result =
      stereo::ComputeDisparity(hdr[0], hdr[1], hdr_options);
  ASSERT_TRUE(ldr_result.ok()) << ldr_result.status();
  ASSERT_TRUE(hdr_result.ok()) << hdr_result.status();
  const Score ldr_score = Evaluate(ldr_result->disparity, capture.truth[0]);
  const Score hdr_score = Evaluate(hdr_result->disparity, capture.truth[0]);
  std::cout << GetParam() << " RMSE / within 0.5 px: structured light "
            << sl.rmse() << " / " << sl.within() * 100 << "%, LDR CVF "
            << ldr_score.rmse() << " / " << ldr_score.within() * 100
            << "%, HDR CVF " << hdr_score.rmse() << " / "
            << hdr_score.within() * 100 << "%\n";
  for (const Score* matcher : {&ldr_score, &hdr_score}) {
    EXPECT_LT(sl.rmse(), matcher->rmse());
    EXPECT_GT(sl.within(), matcher->within());
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, SimGroundTruthTest,
                         ::testing::Values("lab-lamp", "shadowed"),
                         [](const auto& info) {
                           return std::string(info.param) == "lab-lamp"
                                      ? std::string("LabLamp")
                                      : std::string("Shadowed");
                         });

TEST(GroundTruthTest, WritesMiddleburyFiles) {
  const testing::SimCapture capture =
      testing::RenderSimCapture("shadowed", {1.0 / 30}, 128);
  absl::StatusOr<DecodedView> left = Decode(capture.views[0]);
  absl::StatusOr<DecodedView> right = Decode(capture.views[1]);
  ASSERT_TRUE(left.ok() && right.ok());
  absl::StatusOr<GroundTruth> gt = ComputeGroundTruth(*left, *right);
  ASSERT_TRUE(gt.ok());
  hdrstereo::testing::TempDir dir;
  ASSERT_TRUE(WriteMiddlebury(*gt, dir.path() / "gt").ok());
  absl::StatusOr<cv::Mat> disp0 = io::ReadPfm(dir.path() / "gt/disp0GT.pfm");
  ASSERT_TRUE(disp0.ok()) << disp0.status();
  cv::Mat a = gt->disp0.clone(), b = disp0->clone();
  a.setTo(-1, a == std::numeric_limits<float>::infinity());
  b.setTo(-1, b == std::numeric_limits<float>::infinity());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "gt/disp1GT.pfm"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "gt/mask0nocc.png"));
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "gt/sl_stats.json"));
}

TEST(GroundTruthTest, UnlitPairGivesAllInvalidMapsWithWarning) {
  DecodedView dark;
  const cv::Size size(40, 30);
  dark.column = cv::Mat(size, CV_32SC1, cv::Scalar(-1));
  dark.row = cv::Mat(size, CV_32SC1, cv::Scalar(-1));
  dark.confidence = cv::Mat(size, CV_32FC1, cv::Scalar(0));
  dark.lit = cv::Mat(size, CV_8UC1, cv::Scalar(0));
  dark.exposure = cv::Mat(size, CV_8UC1, cv::Scalar(255));
  absl::StatusOr<GroundTruth> gt = ComputeGroundTruth(dark, dark);
  ASSERT_TRUE(gt.ok()) << gt.status();
  EXPECT_EQ(gt->stats.view[0].valid, 0);
  EXPECT_EQ(cv::countNonZero(gt->mask0nocc), 0);
  EXPECT_FALSE(gt->warnings.empty());
}

TEST(GroundTruthTest, SizeMismatchIsAnError) {
  DecodedView a, b;
  a.column = cv::Mat(30, 40, CV_32SC1, cv::Scalar(-1));
  b.column = cv::Mat(31, 40, CV_32SC1, cv::Scalar(-1));
  EXPECT_EQ(ComputeGroundTruth(a, b).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace hdrstereo::structured_light
