// SPDX-License-Identifier: GPL-3.0-or-later
//
// StereoOptions: every rule names its field, the matcher refuses what
// Validate() refuses, and the canonical JSON holds every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "processing/stereo/cost_volume_stereo.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::stereo {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using O = StereoOptions;

TEST(StereoOptionsTest, BadOptionsNameTheField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.max_disparity = 0; }, "max_disparity is 0"},
      {[](O& o) { o.min_disparity = 64; }, "min_disparity (64)"},
      {[](O& o) { o.alpha = 1.5; }, "alpha is 1.5"},
      {[](O& o) { o.tau_color = 0; }, "tau_color is 0"},
      {[](O& o) { o.tau_gradient = -1; }, "tau_gradient is -1"},
      {[](O& o) { o.radius = 0; }, "radius is 0"},
      {[](O& o) { o.eps = 0; }, "eps is 0"},
      {[](O& o) { o.lr_tolerance = -1; }, "lr_tolerance is -1"},
      {[](O& o) { o.median_radius = 0; }, "median_radius is 0"},
      {[](O& o) { o.sigma_s = 0; }, "sigma_s is 0"},
      {[](O& o) { o.sigma_c = -0.1; }, "sigma_c is -0.1"},
      {[](O& o) { o.hdr_white_percentile = 101; },
       "hdr_white_percentile is 101"},
      {[](O& o) { o.threads = -2; }, "threads is -2"},
  });
  EXPECT_OK(O::Hdr().Validate());
  // The weighted median's parameters matter only when it runs.
  O no_median;
  no_median.weighted_median = false;
  no_median.median_radius = 0;
  EXPECT_OK(no_median.Validate());
}

TEST(StereoOptionsTest, MatcherRefusesWhatValidateRefuses) {
  const cv::Mat image(16, 32, CV_8UC1, cv::Scalar(100));
  O o;
  o.max_disparity = 8;
  o.radius = 0;
  EXPECT_THAT(
      ComputeDisparity(image, image, o),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("radius is 0")));
  // The range against the image width is the matcher's own check.
  o.radius = 2;
  o.max_disparity = 40;
  EXPECT_THAT(ComputeDisparity(image, image, o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("wider than the image (32 pixels)")));
}

TEST(StereoOptionsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/min_disparity", [](O& o) { o.min_disparity = 1; }},
      {"/max_disparity", [](O& o) { o.max_disparity = 65; }},
      {"/mode", [](O& o) { o.mode = CostMode::kHdrRadianceGradient; }},
      {"/alpha", [](O& o) { o.alpha = 0.5; }},
      {"/tau_color", [](O& o) { o.tau_color = 0.1; }},
      {"/tau_gradient", [](O& o) { o.tau_gradient = 0.1; }},
      {"/radius", [](O& o) { o.radius = 4; }},
      {"/eps", [](O& o) { o.eps = 1e-3; }},
      {"/left_right_check", [](O& o) { o.left_right_check = false; }},
      {"/lr_tolerance", [](O& o) { o.lr_tolerance = 1; }},
      {"/fill", [](O& o) { o.fill = false; }},
      {"/weighted_median", [](O& o) { o.weighted_median = false; }},
      {"/median_radius", [](O& o) { o.median_radius = 5; }},
      {"/sigma_s", [](O& o) { o.sigma_s = 3; }},
      {"/sigma_c", [](O& o) { o.sigma_c = 0.2; }},
      {"/subpixel", [](O& o) { o.subpixel = true; }},
      {"/gain_compensation", [](O& o) { o.gain_compensation = false; }},
      {"/hdr_white_percentile", [](O& o) { o.hdr_white_percentile = 99; }},
      {"/threads", [](O& o) { o.threads = 1; }},
  });
}

}  // namespace
}  // namespace hdrstereo::stereo
