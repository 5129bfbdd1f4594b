// SPDX-License-Identifier: GPL-3.0-or-later
//
// FusionOptions: every rule names its field, the fusion refuses what
// Validate() refuses, and the canonical JSON holds every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "processing/fusion/fusion.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::fusion {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using O = FusionOptions;

TEST(FusionParamsTest, BadParamsNameTheField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.max_disp = 0; }, "max_disp is 0"},
      {[](O& o) { o.max_disp = 5000; }, "max_disp is 5000"},
      {[](O& o) { o.sigma = 0; }, "sigma is 0"},
      {[](O& o) { o.data_scale = -1; }, "data_scale is -1"},
      {[](O& o) { o.data_truncation = 0; }, "data_truncation is 0"},
      {[](O& o) { o.lambda = -1; }, "lambda is -1"},
      {[](O& o) { o.lambda = 2e4; }, "lambda is 20000"},
      {[](O& o) { o.linear_model_thr = 0.5; }, "linear_model_thr is 0.5"},
      {[](O& o) { o.quadratic_truncation = 0; }, "quadratic_truncation is 0"},
      {[](O& o) { o.edge_weight = 1.5; }, "edge_weight is 1.5"},
      {[](O& o) { o.max_cycles = -1; }, "max_cycles is -1"},
      {[](O& o) { o.candidate_label_radius = -1; },
       "candidate_label_radius is -1"},
  });
}

TEST(FusionParamsTest, FusionRefusesWhatValidateRefuses) {
  const cv::Mat candidate(8, 8, CV_32FC1, cv::Scalar(3));
  const cv::Mat guide(8, 8, CV_8UC1, cv::Scalar(50));
  O o;
  o.max_disp = 8;
  o.edge_weight = 2;
  EXPECT_THAT(FuseAlphaExpansion({candidate}, guide, o),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("fusion: edge_weight is 2")));
}

TEST(FusionParamsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/max_disp", [](O& o) { o.max_disp = 32; }},
      {"/data", [](O& o) { o.data = DataModel::kQuadratic; }},
      {"/sigma", [](O& o) { o.sigma = 2; }},
      {"/data_scale", [](O& o) { o.data_scale = 32; }},
      {"/data_truncation", [](O& o) { o.data_truncation = 8; }},
      {"/smoothness", [](O& o) { o.smoothness = SmoothnessModel::kPotts; }},
      {"/lambda", [](O& o) { o.lambda = 2; }},
      {"/linear_model_thr", [](O& o) { o.linear_model_thr = 20; }},
      {"/static_cue", [](O& o) { o.static_cue = 4; }},
      {"/quadratic_c", [](O& o) { o.quadratic_c = 10; }},
      {"/quadratic_truncation", [](O& o) { o.quadratic_truncation = 2; }},
      {"/edge_weight", [](O& o) { o.edge_weight = 0.5; }},
      {"/max_cycles", [](O& o) { o.max_cycles = 3; }},
      {"/prune_dominated", [](O& o) { o.prune_dominated = false; }},
      {"/candidate_labels_only", [](O& o) { o.candidate_labels_only = true; }},
      {"/candidate_label_radius", [](O& o) { o.candidate_label_radius = 2; }},
  });
}

}  // namespace
}  // namespace hdrstereo::fusion
