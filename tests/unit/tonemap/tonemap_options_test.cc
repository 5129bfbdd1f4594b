// SPDX-License-Identifier: GPL-3.0-or-later
//
// tonemap::Params (with the operators' and filters' parameters): every rule
// names its field, tone mapping refuses what Validate() refuses, and the
// canonical JSON holds every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>

#include "processing/tonemap/tonemap.h"
#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::tonemap {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using P = Params;
using WlsPreconditioner = filters::WlsOptions::Preconditioner;

TEST(ToneMapParamsTest, BadParamsNameTheField) {
  ExpectRulesNameTheirField<P>({
      {[](P& p) { p.saturation = -1; }, "saturation is -1"},
      {[](P& p) { p.gamma = 0; }, "gamma is 0"},
      {[](P& p) { p.clip_low = -0.1; }, "clip_low is -0.1"},
      {[](P& p) { p.clip_high = -0.1; }, "clip_high is -0.1"},
      {[](P& p) { p.clip_low = p.clip_high = 0.3; },
       "clip_low + clip_high is 0.6"},
      {[](P& p) { p.base_contrast = 1; }, "base_contrast is 1"},
      {[](P& p) { p.reinhard.key = 0; }, "reinhard.key is 0"},
      {[](P& p) { p.reinhard.white = std::numeric_limits<double>::infinity(); },
       "reinhard.white is inf"},
      {[](P& p) { p.drago.bias = 1; }, "drago.bias is 1"},
      {[](P& p) { p.drago.ld_max = 0; }, "drago.ld_max is 0"},
      {[](P& p) { p.durand.sigma_s_fraction = 0; },
       "durand.sigma_s_fraction is 0"},
      {[](P& p) { p.durand.sigma_r = -1; }, "durand.sigma_r is -1"},
      {[](P& p) { p.fattal.alpha = 0; }, "fattal.alpha is 0"},
      {[](P& p) { p.fattal.beta = 1.5; }, "fattal.beta is 1.5"},
      {[](P& p) { p.fattal.min_level_size = 1; }, "fattal.min_level_size is 1"},
      {[](P& p) { p.fattal.solve_width = 40; },
       "fattal.solve_width is 40; it must be 0 (the views' size) or >= 2 x "
       "min_level_size"},
      {[](P& p) { p.guided.radius = 0; }, "guided.radius is 0"},
      {[](P& p) { p.guided.eps = 0; }, "guided.eps is 0"},
      {[](P& p) { p.guided.subsample = 0; }, "guided.subsample is 0"},
      {[](P& p) { p.domain_transform.sigma_s = 0; },
       "domain_transform.sigma_s is 0"},
      {[](P& p) { p.domain_transform.sigma_r = 0; },
       "domain_transform.sigma_r is 0"},
      {[](P& p) { p.domain_transform.iterations = 0; },
       "domain_transform.iterations is 0"},
      {[](P& p) { p.wls.alpha = 0; }, "wls.alpha is 0"},
      {[](P& p) { p.wls.lambda = -1; }, "wls.lambda is -1"},
      {[](P& p) { p.wls.small_number = 0; }, "wls.small_number is 0"},
      {[](P& p) { p.wls.tolerance = 0; }, "wls.tolerance is 0"},
      {[](P& p) { p.wls.max_iterations = 0; }, "wls.max_iterations is 0"},
  });
}

TEST(ToneMapParamsTest, ToneMappingRefusesWhatValidateRefuses) {
  const cv::Mat radiance(8, 8, CV_32FC3, cv::Scalar(1, 2, 3));
  P p;
  p.gamma = -2;
  EXPECT_THAT(ToneMap(radiance, Operator::kReinhard, p),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("tone mapping: gamma is -2")));
}

TEST(ToneMapParamsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<P>({
      {"/saturation", [](P& p) { p.saturation = 0.5; }},
      {"/gamma", [](P& p) { p.gamma = 2.4; }},
      {"/clip_low", [](P& p) { p.clip_low = 0.01; }},
      {"/clip_high", [](P& p) { p.clip_high = 0.01; }},
      {"/base_contrast", [](P& p) { p.base_contrast = 4; }},
      {"/reinhard/key", [](P& p) { p.reinhard.key = 0.36; }},
      {"/reinhard/white", [](P& p) { p.reinhard.white = 2; }},
      {"/drago/bias", [](P& p) { p.drago.bias = 0.8; }},
      {"/drago/ld_max", [](P& p) { p.drago.ld_max = 200; }},
      {"/durand/sigma_s_fraction", [](P& p) { p.durand.sigma_s_fraction = 1; }},
      {"/durand/sigma_r", [](P& p) { p.durand.sigma_r = 0.3; }},
      {"/fattal/alpha", [](P& p) { p.fattal.alpha = 0.2; }},
      {"/fattal/beta", [](P& p) { p.fattal.beta = 0.9; }},
      {"/fattal/min_level_size", [](P& p) { p.fattal.min_level_size = 16; }},
      {"/fattal/solve_width", [](P& p) { p.fattal.solve_width = 640; }},
      {"/guided/radius", [](P& p) { p.guided.radius = 4; }},
      {"/guided/eps", [](P& p) { p.guided.eps = 1e-3; }},
      {"/guided/subsample", [](P& p) { p.guided.subsample = 2; }},
      {"/domain_transform/sigma_s",
       [](P& p) { p.domain_transform.sigma_s = 30; }},
      {"/domain_transform/sigma_r",
       [](P& p) { p.domain_transform.sigma_r = 0.2; }},
      {"/domain_transform/iterations",
       [](P& p) { p.domain_transform.iterations = 2; }},
      {"/wls/alpha", [](P& p) { p.wls.alpha = 1.4; }},
      {"/wls/lambda", [](P& p) { p.wls.lambda = 0.5; }},
      {"/wls/small_number", [](P& p) { p.wls.small_number = 1e-3; }},
      {"/wls/tolerance", [](P& p) { p.wls.tolerance = 1e-3; }},
      {"/wls/max_iterations", [](P& p) { p.wls.max_iterations = 100; }},
      {"/wls/preconditioner",
       [](P& p) {
         p.wls.preconditioner = WlsPreconditioner::kIncompleteCholesky;
       }},
  });
}

}  // namespace
}  // namespace hdrstereo::tonemap
