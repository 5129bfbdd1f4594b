// SPDX-License-Identifier: GPL-3.0-or-later
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>

#include "processing/eval/disparity_eval.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::eval {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(EvaluateDisparityTest, HandComputedMetrics) {
  // Truth 10 everywhere except one unknown pixel; errors 0, 0.75, 1.5, 3,
  // 5, NaN estimate, and one pixel with unknown truth.
  const cv::Mat gt = (cv::Mat_<float>(1, 7) << 10, 10, 10, 10, 10, 10, kInf);
  const cv::Mat d = (cv::Mat_<float>(1, 7) << 10, 10.75, 8.5, 13, 15, kNaN, 3);
  const cv::Mat nonocc =
      (cv::Mat_<uint8_t>(1, 7) << 255, 255, 255, 0, 0, 255, 255);
  absl::StatusOr<DisparityEvaluation> e = EvaluateDisparity(d, gt, nonocc);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->all.pixels, 6);
  EXPECT_EQ(e->all.estimated, 5);
  EXPECT_NEAR(e->all.rmse, std::sqrt((0 + 0.5625 + 2.25 + 9 + 25) / 5.0), 1e-9);
  EXPECT_NEAR(e->all.mae, (0 + 0.75 + 1.5 + 3 + 5) / 5.0, 1e-9);
  // > 0.5: 0.75, 1.5, 3, 5 + missing = 5 of 6.
  EXPECT_NEAR(e->all.bad_percent[0], 100.0 * 5 / 6, 1e-9);
  EXPECT_NEAR(e->all.bad_percent[1], 100.0 * 4 / 6, 1e-9);
  EXPECT_NEAR(e->all.bad_percent[2], 100.0 * 3 / 6, 1e-9);
  EXPECT_NEAR(e->all.bad_percent[3], 100.0 * 2 / 6, 1e-9);
  // Non-occluded: pixels 0, 1, 2, 5.
  EXPECT_EQ(e->nonoccluded.pixels, 4);
  EXPECT_NEAR(e->nonoccluded.bad_percent[1], 100.0 * 2 / 4, 1e-9);
  // Valid: estimate and truth both valid.
  EXPECT_EQ(e->valid.pixels, 5);
  EXPECT_NEAR(e->valid.bad_percent[3], 100.0 * 1 / 5, 1e-9);
  // User mask keeps pixels 0 and 4 only.
  const cv::Mat mask = (cv::Mat_<uint8_t>(1, 7) << 1, 0, 0, 0, 1, 0, 0);
  absl::StatusOr<DisparityEvaluation> m = EvaluateDisparity(d, gt, {}, mask);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->all.pixels, 2);
  EXPECT_EQ(m->nonoccluded.pixels, 2);  // no non-occlusion mask: = all
  EXPECT_NEAR(m->all.rmse, std::sqrt(25 / 2.0), 1e-9);
}

TEST(EvaluateDisparityTest, ZeroTruthIsUnknownByDefault) {
  const cv::Mat gt = (cv::Mat_<float>(1, 2) << 0, 4);
  const cv::Mat d = (cv::Mat_<float>(1, 2) << 1, 4);
  EXPECT_EQ(EvaluateDisparity(d, gt)->all.pixels, 1);
  EvalOptions o;
  o.gt_zero_valid = true;
  EXPECT_EQ(EvaluateDisparity(d, gt, {}, {}, o)->all.pixels, 2);
  o.disparity_scale = 2.0;
  EXPECT_NEAR(EvaluateDisparity(d, gt, {}, {}, o)->all.mae, (2 + 4) / 2.0,
              1e-9);
}

TEST(EvaluateDisparityTest, JsonAndText) {
  const cv::Mat gt(4, 4, CV_32FC1, cv::Scalar(5));
  absl::StatusOr<DisparityEvaluation> e = EvaluateDisparity(gt, gt);
  ASSERT_TRUE(e.ok());
  const std::string text = EvaluationToJson(*e);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << text;
  EXPECT_EQ(j.at("thresholds"), nlohmann::json({0.5, 1.0, 2.0, 4.0}));
  EXPECT_EQ(j.at("nonoccluded").at("pixels"), 16);
  EXPECT_EQ(j.at("nonoccluded").at("coverage"), 1.0);
  EXPECT_EQ(j.at("valid").at("bad").at("1"), 0.0);
  EXPECT_EQ(j.at("all").at("bad").at("0.5"), 0.0);
  EXPECT_NE(EvaluationToText(*e).find("valid"), std::string::npos);
}

// A NaN or infinite metric (an RMSE whose sum of squares overflowed) must
// still give valid JSON: nlohmann writes it as null.
TEST(EvaluateDisparityTest, NonFiniteMetricsGiveValidJson) {
  DisparityEvaluation e;
  e.thresholds = {0.5, 1e-7};
  e.all = {.pixels = 4,
           .estimated = 4,
           .coverage = 1,
           .rmse = std::numeric_limits<double>::infinity(),
           .mae = std::numeric_limits<double>::quiet_NaN(),
           .bad_percent = {25, -std::numeric_limits<double>::infinity()}};
  e.nonoccluded = e.all;
  e.valid = e.all;
  const std::string text = EvaluationToJson(e);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << text;
  for (const char* region : {"all", "nonoccluded", "valid"}) {
    SCOPED_TRACE(region);
    EXPECT_TRUE(j.at(region).at("rmse").is_null());
    EXPECT_TRUE(j.at(region).at("mae").is_null());
    EXPECT_EQ(j.at(region).at("pixels"), 4);
    EXPECT_EQ(j.at(region).at("bad").at("0.5"), 25.0);
    EXPECT_TRUE(j.at(region).at("bad").at("1e-07").is_null());
  }
  EXPECT_EQ(j.at("thresholds"), nlohmann::json({0.5, 1e-7}));
}

TEST(EvaluateDisparityTest, BadInput) {
  const cv::Mat a(4, 4, CV_32FC1, cv::Scalar(1));
  EXPECT_THAT(EvaluateDisparity(cv::Mat(), a),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("disparity or ground truth is empty")));
  EXPECT_THAT(
      EvaluateDisparity(a, cv::Mat(4, 5, CV_32FC1)),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("disparity (4x4) and ground truth (5x4) differ in size")));
  EXPECT_THAT(
      EvaluateDisparity(a, cv::Mat(4, 4, CV_8UC1)),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr(
                   "disparity and ground truth must be single-channel float")));
  EXPECT_THAT(EvaluateDisparity(a, a, cv::Mat(3, 4, CV_8UC1)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("non-occlusion mask must be an 8-bit")));
  EXPECT_THAT(EvaluateDisparity(a, a, {}, cv::Mat(4, 4, CV_32FC1)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("mask must be an 8-bit")));
}

TEST(ColorizeTest, InvalidIsBlackValidIsNot) {
  const cv::Mat d = (cv::Mat_<float>(1, 4) << 0, 10, kNaN, kInf);
  absl::StatusOr<cv::Mat> c = ColorizeDisparity(d, 0, 10);
  ASSERT_TRUE(c.ok());
  ASSERT_EQ(c->type(), CV_8UC3);
  EXPECT_EQ(c->at<cv::Vec3b>(0, 2), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(c->at<cv::Vec3b>(0, 3), cv::Vec3b(0, 0, 0));
  EXPECT_NE(c->at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  EXPECT_NE(c->at<cv::Vec3b>(0, 0), c->at<cv::Vec3b>(0, 1));
  const cv::Mat gt = (cv::Mat_<float>(1, 4) << 0.5f, 10, 3, 3);
  absl::StatusOr<cv::Mat> err = ColorizeError(d, gt, 4.0);
  ASSERT_TRUE(err.ok());
  EXPECT_NE(err->at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));  // error 0.5
  EXPECT_NE(err->at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 0));  // error 0
  EXPECT_EQ(err->at<cv::Vec3b>(0, 2), cv::Vec3b(0, 0, 0));
  EXPECT_THAT(
      ColorizeDisparity(cv::Mat()),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr(
              "disparity must be a non-empty single-channel float image")));
  EXPECT_THAT(ColorizeError(d, gt, 0),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("max_error must be > 0")));
}

}  // namespace
}  // namespace hdrstereo::eval
