// SPDX-License-Identifier: GPL-3.0-or-later
//
// ArtifactRepository on a real SQLite store: a step's artifacts found by
// their input hash, replaced per step and per path, listed in pages, and
// the metrics rows replaced and ordered.
#include "daemon/store/artifact_repository.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "tests/support/store_fixture.h"

namespace hdrstereo::store {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

ArtifactRecord Artifact(const std::string& path, const std::string& kind,
                        const std::string& hash) {
  ArtifactRecord a;
  a.kind = kind;
  a.path = path;
  a.params_json = "{}";
  a.params_hash = hash;
  a.sha256 = "sha-" + path;
  a.size_bytes = static_cast<int64_t>(path.size());
  return a;
}

std::vector<std::string> Paths(const std::vector<ArtifactRecord>& rows) {
  std::vector<std::string> out;
  for (const ArtifactRecord& a : rows) out.push_back(a.path);
  return out;
}

class ArtifactRepositoryTest : public testing::StoreTest {};

TEST_F(ArtifactRepositoryTest, StepArtifactsAreFoundByTheirInputHash) {
  ASSERT_OK_AND_ASSIGN(const SessionRecord s, Session("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab", JobKind::kProcessing));
  ArtifactRepository artifacts(*store_);
  ASSERT_OK(artifacts.ReplaceStep(s.id, job.id, "hdr",
                                  {Artifact("hdr/im0.pfm", "hdr", "h1"),
                                   Artifact("hdr/im1.pfm", "hdr", "h1")}));
  ASSERT_OK_AND_ASSIGN(const std::vector<ArtifactRecord> found,
                       artifacts.ForStep(s.id, "hdr", "h1"));
  EXPECT_EQ(Paths(found),
            (std::vector<std::string>{"hdr/im0.pfm", "hdr/im1.pfm"}));
  EXPECT_EQ(found[0].step, "hdr");
  EXPECT_EQ(found[0].job_id, job.id);
  EXPECT_EQ(found[0].sha256, "sha-hdr/im0.pfm");
  EXPECT_EQ(found[0].size_bytes, 11);
  EXPECT_GT(found[0].create_time_ms, 0);
  // Another hash, another step or another session: nothing.
  EXPECT_TRUE(artifacts.ForStep(s.id, "hdr", "h2")->empty());
  EXPECT_TRUE(artifacts.ForStep(s.id, "tonemap", "h1")->empty());
  EXPECT_TRUE(artifacts.ForStep(s.id + 1, "hdr", "h1")->empty());
}

TEST_F(ArtifactRepositoryTest, ReplacingAStepDropsItsOldRowsAndThePathsRows) {
  ASSERT_OK_AND_ASSIGN(const SessionRecord s, Session("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab", JobKind::kProcessing));
  ArtifactRepository artifacts(*store_);
  ASSERT_OK(artifacts.ReplaceStep(s.id, job.id, "stereo",
                                  {Artifact("disparity/ldr.pfm", "d", "a"),
                                   Artifact("disparity/hdr.pfm", "d", "a")}));
  ASSERT_OK(artifacts.ReplaceStep(s.id, job.id, "fusion",
                                  {Artifact("disparity/fused.pfm", "d", "b")}));
  // stereo again, with a path that fusion had recorded.
  ASSERT_OK(artifacts.ReplaceStep(s.id, job.id, "stereo",
                                  {Artifact("disparity/ldr.pfm", "d", "c"),
                                   Artifact("disparity/fused.pfm", "d", "c")}));
  EXPECT_TRUE(artifacts.ForStep(s.id, "stereo", "a")->empty());
  // The path fusion had keeps its row (and id), now stereo's.
  EXPECT_THAT(Paths(*artifacts.ForStep(s.id, "stereo", "c")),
              UnorderedElementsAre("disparity/ldr.pfm", "disparity/fused.pfm"));
  EXPECT_TRUE(artifacts.ForStep(s.id, "fusion", "b")->empty());
  ASSERT_OK_AND_ASSIGN(const std::vector<ArtifactRecord> all,
                       artifacts.List("lab", "", 0, 100));
  EXPECT_EQ(all.size(), 2u);
}

TEST_F(ArtifactRepositoryTest, ListPagesByIdAndKindAndGetNamesWhatIsMissing) {
  ASSERT_OK_AND_ASSIGN(const SessionRecord s, Session("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab", JobKind::kProcessing));
  ArtifactRepository artifacts(*store_);
  ASSERT_OK(
      artifacts.ReplaceStep(s.id, job.id, "report",
                            {Artifact("report/a.png", "report", "r"),
                             Artifact("report/b.png", "report", "r"),
                             Artifact("report/index.html", "page", "r")}));
  ASSERT_OK_AND_ASSIGN(const std::vector<ArtifactRecord> first,
                       artifacts.List("lab", "", 0, 2));
  ASSERT_EQ(first.size(), 2u);
  ASSERT_OK_AND_ASSIGN(const std::vector<ArtifactRecord> rest,
                       artifacts.List("lab", "", first.back().id, 2));
  EXPECT_EQ(Paths(rest), std::vector<std::string>{"report/index.html"});
  EXPECT_EQ(Paths(*artifacts.List("lab", "report", 0, 10)),
            (std::vector<std::string>{"report/a.png", "report/b.png"}));
  ASSERT_OK_AND_ASSIGN(const ArtifactRecord got,
                       artifacts.Get("lab", rest[0].id));
  EXPECT_EQ(got.path, "report/index.html");
  EXPECT_THAT(artifacts.List("nope", "", 0, 10),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("nope")));
  EXPECT_THAT(artifacts.Get("lab", 9999),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("9999")));
  EXPECT_THAT(artifacts.Get("nope", rest[0].id),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("nope")));
}

TEST_F(ArtifactRepositoryTest, MetricsAreReplacedAndOrderedByTruthThenRmse) {
  ASSERT_OK_AND_ASSIGN(const SessionRecord s, Session("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab", JobKind::kProcessing));
  ArtifactRepository artifacts(*store_);
  auto metric = [&](const char* method, const char* truth, double rmse) {
    MetricRecord m;
    m.method = method;
    m.ground_truth = truth;
    m.rmse = rmse;
    m.bad_1 = 2 * rmse;
    m.job_id = job.id;
    return m;
  };
  ASSERT_OK(artifacts.ReplaceMetrics(s.id, job.id,
                                     {metric("ldr", "simulation", 1.5)}));
  ASSERT_OK(artifacts.ReplaceMetrics(
      s.id, job.id,
      {metric("ldr", "structured_light", 1.2),
       metric("fused", "simulation", 0.8), metric("ldr", "simulation", 1.3)}));
  ASSERT_OK_AND_ASSIGN(const std::vector<MetricRecord> rows,
                       artifacts.Metrics(s.id));
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].method, "fused");
  EXPECT_EQ(rows[0].ground_truth, "simulation");
  EXPECT_EQ(rows[1].method, "ldr");
  EXPECT_DOUBLE_EQ(rows[1].rmse, 1.3);  // the earlier 1.5 is gone
  EXPECT_DOUBLE_EQ(rows[1].bad_1, 2.6);
  EXPECT_EQ(rows[2].ground_truth, "structured_light");
  EXPECT_EQ(rows[2].job_id, job.id);
}

// A metric that could not be computed is NaN; SQLite stores it as NULL.
// It must read back as NaN, not as a perfect 0, and sort after the numbers.
TEST_F(ArtifactRepositoryTest, AMetricThatCouldNotBeComputedStaysNaN) {
  ASSERT_OK_AND_ASSIGN(const SessionRecord s, Session("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab", JobKind::kProcessing));
  ArtifactRepository artifacts(*store_);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  MetricRecord failed{.method = "fattal", .ground_truth = "simulation"};
  failed.rmse = nan;
  failed.bad_1 = nan;
  MetricRecord fine{.method = "ldr", .ground_truth = "simulation"};
  fine.rmse = 1.5;
  ASSERT_OK(artifacts.ReplaceMetrics(s.id, job.id, {failed, fine}));
  ASSERT_OK_AND_ASSIGN(const std::vector<MetricRecord> rows,
                       artifacts.Metrics(s.id));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].method, "ldr");
  EXPECT_DOUBLE_EQ(rows[0].rmse, 1.5);
  EXPECT_EQ(rows[1].method, "fattal");
  EXPECT_TRUE(std::isnan(rows[1].rmse));
  EXPECT_TRUE(std::isnan(rows[1].bad_1));
  EXPECT_DOUBLE_EQ(rows[1].mae, 0);  // stored as the number it was
}

}  // namespace
}  // namespace hdrstereo::store
