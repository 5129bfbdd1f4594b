// SPDX-License-Identifier: GPL-3.0-or-later
//
// ResponseOptions and MergeOptions: every rule names its field, recovery
// and merge refuse what Validate() refuses, and the canonical JSON holds
// every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <vector>

#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::hdr {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

ExposureStack TwoExposures() {
  ExposureStack stack;
  stack.images = {cv::Mat(8, 8, CV_8UC3, cv::Scalar(200, 150, 100)),
                  cv::Mat(8, 8, CV_8UC3, cv::Scalar(100, 75, 50))};
  stack.exposure_s = {0.1, 0.05};
  return stack;
}

TEST(ResponseOptionsTest, BadOptionsNameTheField) {
  ExpectRulesNameTheirField<ResponseOptions>({
      {[](ResponseOptions& o) { o.lambda = -1; }, "lambda is -1"},
      {[](ResponseOptions& o) { o.samples = 1; }, "samples is 1"},
  });
  ResponseOptions o;
  o.samples = 0;
  EXPECT_THAT(RecoverResponse(TwoExposures(), o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("response: samples is 0")));
}

TEST(ResponseOptionsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<ResponseOptions>({
      {"/lambda", [](ResponseOptions& o) { o.lambda = 20; }},
      {"/samples", [](ResponseOptions& o) { o.samples = 60; }},
      {"/seed", [](ResponseOptions& o) { o.seed = 2; }},
  });
}

TEST(MergeOptionsTest, BadOptionsNameTheField) {
  ExpectRulesNameTheirField<MergeOptions>({
      {[](MergeOptions& o) { o.weights.assign(10, 1.0f); },
       "weights has 10 entries"},
      {[](MergeOptions& o) {
         o.weights.assign(kLevels, 1.0f);
         o.weights[7] = -1.0f;
       },
       "weights[7] is -1"},
      {[](MergeOptions& o) { o.linear_saturation = 0; },
       "linear_saturation is 0"},
      {[](MergeOptions& o) { o.linear_saturation = 1.5; },
       "linear_saturation is 1.5"},
  });
  MergeOptions o;
  o.weights.assign(3, 1.0f);
  EXPECT_THAT(MergeStack(TwoExposures(), LinearResponse(), o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("merge: weights has 3 entries")));
}

TEST(MergeOptionsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<MergeOptions>({
      {"/weights", [](MergeOptions& o) { o.weights = HatWeights(); }},
      {"/per_channel_weights",
       [](MergeOptions& o) { o.per_channel_weights = false; }},
      {"/linear_saturation",
       [](MergeOptions& o) { o.linear_saturation = 0.9; }},
  });
}

}  // namespace
}  // namespace hdrstereo::hdr
