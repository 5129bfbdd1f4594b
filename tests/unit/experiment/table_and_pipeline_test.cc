// SPDX-License-Identifier: GPL-3.0-or-later
//
// One thesis experiment: a simulated session (lab-lamp, 160 px, five
// exposures, exact truth, no structured light so that both take the
// disparity range from the same truth) processed by the pipeline, and its
// rectified stacks with that truth given to the thesis table, in process
// and through hdrstereo-proc table. Every method the session has gets
// exactly the table's RMSE and bad-1px.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/experiment/method.h"
#include "processing/experiment/thesis_table.h"
#include "processing/hdr/stack.h"
#include "processing/io/capture_layout.h"
#include "processing/io/hdr_formats.h"
#include "processing/pipeline/pipeline.h"
#include "processing/pipeline/session_files.h"
#include "tests/support/proc_tool.h"
#include "tests/support/sim_session.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::experiment {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::TempDir;

class Quiet : public pipeline::RunObserver {
 public:
  absl::Status Checkpoint() override { return absl::OkStatus(); }
  void Progress(int64_t, int64_t, const std::string&) override {}
  void Info(const std::string&) override {}
  void Warn(const std::string&) override {}
  void StepComputed(const std::string&, absl::Duration) override {}
};

TEST(ThesisExperimentTest, TableAndProcessedSessionAgree) {
  TempDir tmp;
  const fs::path dir = tmp / "session";
  testing::SimSessionOptions session;
  session.width = 160;
  session.structured_light = false;
  ASSERT_OK(testing::RenderSimSession(dir, session));
  ASSERT_OK_AND_ASSIGN(const pipeline::SessionInput in,
                       pipeline::DiscoverSession(dir));
  ASSERT_OK_AND_ASSIGN(pipeline::JsonRunStore store,
                       pipeline::JsonRunStore::Open(dir / "state.json"));
  Quiet quiet;
  ASSERT_OK_AND_ASSIGN(const pipeline::RunSummary summary,
                       pipeline::Run(in, {}, store, quiet));
  std::map<std::string, const pipeline::Metric*> session_rows;
  for (const pipeline::Metric& m : summary.metrics) {
    ASSERT_EQ(m.ground_truth, "simulation");
    session_rows[m.method] = &m;
  }
  ASSERT_EQ(session_rows.size(), SessionMethods().size());

  const std::string truth_dir = (dir / io::TruthDir(1)).string();
  TableInput table;
  table.name = "session";
  ASSERT_OK_AND_ASSIGN(table.left, hdr::LoadStack(dir / "exposures/left"));
  ASSERT_OK_AND_ASSIGN(table.right, hdr::LoadStack(dir / "exposures/right"));
  ASSERT_OK_AND_ASSIGN(table.truth, io::ReadPfm(truth_dir + "/disp0.pfm"));
  table.nonoccluded =
      cv::imread(truth_dir + "/nonocc0.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(table.nonoccluded.empty());
  ASSERT_OK_AND_ASSIGN(const TableResult result, RunThesisTable(table));
  int compared = 0;
  for (const TableRow& row : result.rows) {
    auto it = session_rows.find(MethodName(row.method));
    if (it == session_rows.end()) {
      EXPECT_EQ(row.method, Method::kFused4);  // the table's own row
      continue;
    }
    EXPECT_DOUBLE_EQ(row.rmse, it->second->rmse) << MethodName(row.method);
    EXPECT_DOUBLE_EQ(row.bad1, it->second->bad_1) << MethodName(row.method);
    ++compared;
  }
  EXPECT_EQ(compared, static_cast<int>(SessionMethods().size()));

  // The command line prints the session's numbers (to its precision).
  const testing::CommandResult r = testing::Proc(
      {"table", "--left-stack", (dir / "exposures/left").string(),
       "--right-stack", (dir / "exposures/right").string(), "--truth",
       truth_dir + "/disp0.pfm", "--nonoccluded", truth_dir + "/nonocc0.png"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (Method m : SessionMethods()) {
    const pipeline::Metric& row = *session_rows.at(MethodName(m));
    EXPECT_THAT(
        r.out, ::testing::HasSubstr(absl::StrFormat(
                   "| %s | %.2f | %.1f |", MethodName(m), row.rmse, row.bad_1)))
        << r.out;
  }
}

}  // namespace
}  // namespace hdrstereo::experiment
