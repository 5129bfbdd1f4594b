// SPDX-License-Identifier: GPL-3.0-or-later
//
// EvalOptions: every rule names its field, the evaluation refuses what
// Validate() refuses, and the canonical JSON holds every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "processing/eval/disparity_eval.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::eval {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using O = EvalOptions;

TEST(EvalOptionsTest, BadOptionsNameTheField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) {
         o.thresholds = {0.5, -1};
       },
       "thresholds[1] is -1"},
      {[](O& o) { o.disparity_scale = 0; }, "disparity_scale is 0"},
  });
  const cv::Mat d(4, 4, CV_32FC1, cv::Scalar(2));
  O o;
  o.disparity_scale = -1;
  EXPECT_THAT(EvaluateDisparity(d, d, cv::Mat(), cv::Mat(), o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("evaluation: disparity_scale is -1")));
  EXPECT_THAT(ColorizeError(d, d, 4.0, o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("disparity_scale is -1")));
}

TEST(EvalOptionsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/thresholds",
       [](O& o) {
         o.thresholds = {1, 3};
       }},
      {"/gt_zero_valid", [](O& o) { o.gt_zero_valid = true; }},
      {"/disparity_scale", [](O& o) { o.disparity_scale = 0.25; }},
  });
}

}  // namespace
}  // namespace hdrstereo::eval
