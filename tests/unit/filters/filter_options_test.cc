// SPDX-License-Identifier: GPL-3.0-or-later
//
// The filters' options: every rule names its field and each filter refuses
// what Validate() refuses. (Their canonical JSON is checked as part of
// tonemap::Params, which holds all three.)
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "processing/filters/domain_transform.h"
#include "processing/filters/guided_filter.h"
#include "processing/filters/wls_filter.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::filters {
namespace {

using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

const cv::Mat& Image() {
  static const cv::Mat* image = new cv::Mat(16, 16, CV_32FC1, cv::Scalar(0.5));
  return *image;
}

TEST(GuidedFilterOptionsTest, BadOptionsNameTheField) {
  using O = GuidedFilterOptions;
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.radius = 0; }, "radius is 0"},
      {[](O& o) { o.eps = -1; }, "eps is -1"},
      {[](O& o) { o.subsample = 0; }, "subsample is 0"},
  });
  EXPECT_THAT(GuidedFilter::Create(Image(), {.radius = 0}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("guided filter: radius is 0")));
}

TEST(DomainTransformOptionsTest, BadOptionsNameTheField) {
  using O = DomainTransformOptions;
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.sigma_s = 0; }, "sigma_s is 0"},
      {[](O& o) { o.sigma_r = -1; }, "sigma_r is -1"},
      {[](O& o) { o.iterations = 0; }, "iterations is 0"},
  });
  EXPECT_THAT(DomainTransformFilter(Image(), Image(), {.iterations = 0}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("domain transform: iterations is 0")));
}

TEST(WlsOptionsTest, BadOptionsNameTheField) {
  using O = WlsOptions;
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.alpha = 0; }, "alpha is 0"},
      {[](O& o) { o.lambda = -1; }, "lambda is -1"},
      {[](O& o) { o.small_number = 0; }, "small_number is 0"},
      {[](O& o) { o.tolerance = 0; }, "tolerance is 0"},
      {[](O& o) { o.max_iterations = 0; }, "max_iterations is 0"},
  });
  EXPECT_THAT(WlsFilter(Image(), Image(), {.max_iterations = 0}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("WLS: max_iterations is 0")));
}

}  // namespace
}  // namespace hdrstereo::filters
