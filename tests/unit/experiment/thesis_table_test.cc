// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thesis' Tables 5.2/5.3 on the simulator: lab-lamp, two-lamps and
// desk-lamp rendered with the eight thesis exposures at 256 px width, exact
// truth. Asserts the claims where the data supports them (see
// docs/results.md for the table at 320 px and the regenerating command).
#include "processing/experiment/thesis_table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/truth.h"
#include "processing/base/status_macros.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::experiment {
namespace {

absl::StatusOr<TableInput> Render(const std::string& name, int width) {
  ASSIGN_OR_RETURN(sim::Scene scene, sim::LoadScene(name));
  sim::ScaleCamera(scene, width);
  const std::vector<double> times = {1.0 / 15,   1.0 / 30,  1.0 / 60,
                                     1.0 / 125,  1.0 / 250, 1.0 / 500,
                                     1.0 / 1000, 1.0 / 2000};
  sim::SimWorld world(scene);
  TableInput in;
  in.name = name;
  for (double t : times) {
    world.SetStagePosition(0);
    in.left.images.push_back(world.RenderExposure({t, 100}, 8));
    world.SetStagePosition(150);
    in.right.images.push_back(world.RenderExposure({t, 100}, 8));
  }
  in.left.exposure_s = in.right.exposure_s = times;
  ASSIGN_OR_RETURN(const sim::StereoTruth truth, world.Truth(0, 150));
  in.truth = truth.left.disparity;
  in.nonoccluded = truth.left.nonoccluded;
  in.ldr_index = 4;  // 1/250 s
  return in;
}

TEST(ThesisTableTest, FusionBeatsLdrTmosMeanAndMedian) {
  std::vector<TableResult> results;
  for (const std::string name : {"lab-lamp", "two-lamps", "desk-lamp"}) {
    ASSERT_OK_AND_ASSIGN(const TableInput in, Render(name, 256));
    absl::StatusOr<TableResult> r = RunThesisTable(in);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_LE(r->fused_stats.energy_after, r->fused_stats.energy_before);
    results.push_back(*r);
  }
  std::cout << FormatTable(results);
  const double fused7 = MeanRmse(results, Method::kFused);
  const double fused7_bad = MeanBad1(results, Method::kFused);
  const double ldr = MeanRmse(results, Method::kLdr);
  RecordProperty("fused7_rmse", std::to_string(fused7));
  RecordProperty("fused7_bad1", std::to_string(fused7_bad));
  RecordProperty("ldr_rmse", std::to_string(ldr));
  RecordProperty("median_rmse",
                 std::to_string(MeanRmse(results, Method::kMedian)));

  // What the simulated data supports (measured at 256 px, 2026-11-23 and
  // 2026-12-01: fused-7 RMSE 1.44 / bad-1px 12.7 %, LDR 2.16 / 25.3 %,
  // mean 2.13 / 37.9 %, median 1.48 / 16.4 %, the seven TMOs 1.35 .. 5.69,
  // the closest beaten one He (guided) at 1.62): fusion clearly beats LDR
  // matching and the mean, beats the median on bad pixels, and beats the
  // average single TMO and five of the seven.
  EXPECT_LT(fused7, 0.8 * ldr);
  EXPECT_LT(fused7_bad, MeanBad1(results, Method::kLdr) / 1.5);
  EXPECT_LT(fused7, 0.8 * MeanRmse(results, Method::kMean));
  EXPECT_LT(fused7_bad, MeanBad1(results, Method::kMedian));
  EXPECT_LT(fused7, 1.05 * MeanRmse(results, Method::kMedian));
  double tmo_sum = 0;
  int beaten = 0;
  for (Method m : ToneMappedMethods()) {
    const double rmse = MeanRmse(results, m);
    tmo_sum += rmse;
    if (fused7 < rmse) ++beaten;
  }
  EXPECT_LT(fused7, tmo_sum / 7);
  EXPECT_GE(beaten, 5);
  // Not supported here (docs/results.md): the thesis' factor of three over
  // LDR (fused-7 <= LDR / 3 = 1.01 at 320 px, where picking the best
  // candidate per pixel with the truth gives 0.74: the candidates share
  // their errors in the shadows) and fused-7 better than every single TMO
  // (Drago and Reinhard match better on their own).
}

}  // namespace
}  // namespace hdrstereo::experiment
