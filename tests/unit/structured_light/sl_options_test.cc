// SPDX-License-Identifier: GPL-3.0-or-later
//
// The structured-light options: every rule names its field, decoding and
// the ground truth refuse what Validate() refuses, and the canonical JSON
// holds every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "processing/structured_light/decode.h"
#include "processing/structured_light/ground_truth.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::structured_light {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(DecodeOptionsTest, BadOptionsNameTheField) {
  using O = DecodeOptions;
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.min_contrast = -0.1; }, "min_contrast is -0.1"},
      {[](O& o) { o.min_relative_contrast = 2; }, "min_relative_contrast is 2"},
      {[](O& o) { o.min_bits = -1; }, "min_bits is -1"},
      {[](O& o) { o.min_lit = 1.5; }, "min_lit is 1.5"},
      {[](O& o) { o.saturation = 0; }, "saturation is 0"},
  });
  O o;
  o.min_lit = -1;
  EXPECT_THAT(Decode(ViewFrames(), o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("decode: min_lit is -1")));
}

TEST(DecodeOptionsTest, CanonicalJsonHasEveryField) {
  using O = DecodeOptions;
  ExpectJsonHasEveryField<O>({
      {"/min_contrast", [](O& o) { o.min_contrast = 0.01; }},
      {"/min_relative_contrast", [](O& o) { o.min_relative_contrast = 0.5; }},
      {"/min_bits", [](O& o) { o.min_bits = 6; }},
      {"/min_lit", [](O& o) { o.min_lit = 0.02; }},
      {"/saturation", [](O& o) { o.saturation = 0.9; }},
  });
}

TEST(GroundTruthOptionsTest, BadOptionsNameTheField) {
  using O = GroundTruthOptions;
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.match.max_disparity = -1; }, "match.max_disparity is -1"},
      {[](O& o) {
         o.match.min_disparity = 10;
         o.match.max_disparity = 10;
       },
       "match.max_disparity is 10; it must be greater than min_disparity"},
      {[](O& o) { o.match.fit_radius = 0; }, "match.fit_radius is 0"},
      {[](O& o) { o.match.max_code_step = 0; }, "match.max_code_step is 0"},
      {[](O& o) { o.match.max_row_difference = -1; },
       "match.max_row_difference is -1"},
      {[](O& o) { o.match.lr_tolerance = -1; }, "match.lr_tolerance is -1"},
      {[](O& o) { o.projector.max_samples = 11; },
       "projector.max_samples is 11"},
      {[](O& o) { o.projector.ransac_iterations = 0; },
       "projector.ransac_iterations is 0"},
      {[](O& o) { o.projector.inlier_px = 0; }, "projector.inlier_px is 0"},
      {[](O& o) { o.consistency_px = -1; }, "consistency_px is -1"},
      {[](O& o) { o.max_illumination_residual_px = 0; },
       "max_illumination_residual_px is 0"},
      {[](O& o) { o.max_hole_area = -1; }, "max_hole_area is -1"},
      {[](O& o) { o.max_fill_range = -1; }, "max_fill_range is -1"},
  });
  O o;
  o.match.fit_radius = 0;
  EXPECT_THAT(ComputeGroundTruth(DecodedView(), DecodedView(), o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("ground truth: match.fit_radius is 0")));
}

TEST(GroundTruthOptionsTest, CanonicalJsonHasEveryField) {
  using O = GroundTruthOptions;
  ExpectJsonHasEveryField<O>({
      {"/match/min_disparity", [](O& o) { o.match.min_disparity = 2; }},
      {"/match/max_disparity", [](O& o) { o.match.max_disparity = 50; }},
      {"/match/fit_radius", [](O& o) { o.match.fit_radius = 3; }},
      {"/match/max_code_step", [](O& o) { o.match.max_code_step = 4; }},
      {"/match/max_row_difference",
       [](O& o) { o.match.max_row_difference = 2; }},
      {"/match/lr_tolerance", [](O& o) { o.match.lr_tolerance = 2; }},
      {"/projector/max_samples", [](O& o) { o.projector.max_samples = 500; }},
      {"/projector/ransac_iterations",
       [](O& o) { o.projector.ransac_iterations = 10; }},
      {"/projector/inlier_px", [](O& o) { o.projector.inlier_px = 2; }},
      {"/projector/seed", [](O& o) { o.projector.seed = 7; }},
      {"/use_illumination", [](O& o) { o.use_illumination = false; }},
      {"/consistency_px", [](O& o) { o.consistency_px = 2; }},
      {"/max_illumination_residual_px",
       [](O& o) { o.max_illumination_residual_px = 2; }},
      {"/max_hole_area", [](O& o) { o.max_hole_area = 5; }},
      {"/max_fill_range", [](O& o) { o.max_fill_range = 1; }},
  });
}

}  // namespace
}  // namespace hdrstereo::structured_light
