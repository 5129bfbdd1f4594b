// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thesis' Tables 5.2/5.3 on the simulator: lab-lamp, two-lamps and
// desk-lamp rendered with the eight thesis exposures at 256 px width, exact
// truth. Asserts the claims where the data supports them (see
// docs/results.md for the table at 320 px and the regenerating command).
#include "processing/experiment/thesis_table.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "tests/support/thesis_scene.h"

namespace hdrstereo::experiment {
namespace {

// The details' rows against the table's and against each other.
void ExpectConsistentDetails(const TableResult& r) {
  ASSERT_FALSE(r.details.empty());
  const DetailRow& oracle = r.details.back();
  ASSERT_EQ(oracle.approach, "oracle");
  for (const DetailRow& d : r.details) {
    SCOPED_TRACE(d.approach);
    double share = 0;
    for (const RegionScore& region : d.regions) share += region.share;
    EXPECT_NEAR(share, 100.0, 1e-6);
    ASSERT_EQ(d.regions.size(), 5u);
    EXPECT_EQ(d.regions.front().region, "left band");
    EXPECT_GE(d.bad1, d.bad2);
    // At 256 px the scaled threshold is 0.8 px: at least as many bad.
    EXPECT_GE(d.scaled, d.bad1);
    for (const TableRow& row : r.rows) {
      if (MethodName(row.method) != d.approach) continue;
      EXPECT_DOUBLE_EQ(d.rmse, row.rmse);
      EXPECT_DOUBLE_EQ(d.bad1, row.bad1);
      if (std::find(ToneMappedMethods().begin(), ToneMappedMethods().end(),
                    row.method) != ToneMappedMethods().end()) {
        // Per pixel the closest of the seven: never worse than one of them.
        EXPECT_LE(oracle.rmse, row.rmse);
        EXPECT_LE(oracle.bad1, row.bad1);
      }
    }
  }
  EXPECT_NE(FormatDetails({r}).find("| oracle |"), std::string::npos);
}

TEST(ThesisTableTest, FusionBeatsLdrTmosMeanAndMedian) {
  std::vector<TableResult> results;
  for (const std::string name : {"lab-lamp", "two-lamps", "desk-lamp"}) {
    ASSERT_OK_AND_ASSIGN(const TableInput in,
                         testing::RenderThesisScene(name, 256));
    // The thesis' own fusion (fusion_scenes_test has the default one).
    TableOptions options;
    options.experiment.robust_fusion.enabled = false;
    options.details = true;
    absl::StatusOr<TableResult> r = RunThesisTable(in, options);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_LE(r->fused_stats.energy_after, r->fused_stats.energy_before);
    ExpectConsistentDetails(*r);
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
