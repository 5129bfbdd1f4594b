// SPDX-License-Identifier: GPL-3.0-or-later
//
// The pipeline without a daemon: the JSON run store (what a step recorded
// found by its input hash, kept across reopening, a damaged file refused)
// and metrics.json read back and printed in order.
#include "processing/pipeline/session_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "processing/io/atomic_file.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::pipeline {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;

Artifact File(const std::string& path) {
  Artifact a;
  a.step = "hdr";
  a.kind = "hdr";
  a.path = path;
  a.params_json = "{\"merge\":1}";
  a.sha256 = "sha-" + path;
  a.size_bytes = 42;
  return a;
}

Metric Row(const std::string& method, const std::string& truth, double rmse) {
  Metric m;
  m.method = method;
  m.ground_truth = truth;
  m.rmse = rmse;
  m.mae = rmse / 2;
  m.bad_0_5 = 40;
  m.bad_1 = 20;
  m.bad_2 = 10;
  m.bad_4 = 5;
  m.coverage = 99.5;
  return m;
}

TEST(JsonRunStoreTest, RecordsAreFoundByHashAndKeptAcrossReopening) {
  TempDir tmp;
  const auto path = tmp / "state.json";
  {
    ASSERT_OK_AND_ASSIGN(JsonRunStore store, JsonRunStore::Open(path));
    EXPECT_TRUE(store.Lookup("hdr", "h1").empty());  // a new file is empty
    ASSERT_OK(store.Record("hdr", "h1", {File("hdr/im0.pfm")}));
    ASSERT_OK(store.RecordMetrics({Row("fused", "simulation", 0.8)}));
    // A step recorded again replaces what it had.
    ASSERT_OK(
        store.Record("hdr", "h2", {File("hdr/im0.pfm"), File("hdr/im1.pfm")}));
  }
  ASSERT_OK_AND_ASSIGN(JsonRunStore store, JsonRunStore::Open(path));
  EXPECT_TRUE(store.Lookup("hdr", "h1").empty());
  EXPECT_TRUE(store.Lookup("tonemap", "h2").empty());
  const std::vector<Artifact> found = store.Lookup("hdr", "h2");
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[1].path, "hdr/im1.pfm");
  EXPECT_EQ(found[1].sha256, "sha-hdr/im1.pfm");
  EXPECT_EQ(found[1].params_json, "{\"merge\":1}");
  EXPECT_EQ(found[1].size_bytes, 42);
  ASSERT_EQ(store.metrics().size(), 1u);
  EXPECT_EQ(store.metrics()[0].method, "fused");
  EXPECT_DOUBLE_EQ(store.metrics()[0].coverage, 99.5);
}

TEST(JsonRunStoreTest, ADamagedStateFileIsDataLoss) {
  TempDir tmp;
  ASSERT_OK(io::WriteFileAtomically(tmp / "state.json", "{not json"));
  EXPECT_THAT(JsonRunStore::Open(tmp / "state.json"),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("not a pipeline state file")));
}

TEST(MetricsJsonTest, RoundTripAndTheTableInOrder) {
  const std::vector<Metric> rows = {Row("ldr", "simulation", 1.25),
                                    Row("fused", "structured_light", 0.5),
                                    Row("fused", "simulation", 0.75)};
  ASSERT_OK_AND_ASSIGN(const std::vector<Metric> back,
                       MetricsFromJson(MetricsToJson(rows)));
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(back[0].method, "ldr");
  EXPECT_DOUBLE_EQ(back[0].rmse, 1.25);
  EXPECT_DOUBLE_EQ(back[0].bad_4, 5);
  const std::vector<Metric> sorted = SortMetrics(rows);
  EXPECT_EQ(sorted[0].rmse, 0.75);  // simulation first, by RMSE
  EXPECT_EQ(sorted[2].ground_truth, "structured_light");
  EXPECT_THAT(FormatMetrics(rows),
              HasSubstr("| simulation | fused | 0.750 | 0.375 | 40.0 | 20.0 | "
                        "10.0 | 5.0 | 99.5 |\n| simulation | ldr |"));
  EXPECT_THAT(
      MetricsFromJson("{\"rows\": []}"),
      StatusIs(absl::StatusCode::kDataLoss, HasSubstr("not a metrics file")));
}

}  // namespace
}  // namespace hdrstereo::pipeline
