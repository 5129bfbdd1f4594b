// SPDX-License-Identifier: GPL-3.0-or-later
//
// The pipeline without a daemon: the JSON run store (what a step recorded
// found by its input hash, kept across reopening, a damaged file refused),
// metrics.json read back and printed in order, and the request and result
// files of a run done for the daemon elsewhere, with the checks of frames
// and artifacts against their recorded sha256.
#include "processing/pipeline/session_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "processing/io/atomic_file.h"
#include "processing/io/sha256.h"
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

TEST(JobFilesTest, ARequestComesBackWhole) {
  TempDir tmp;
  JobRequest request;
  SessionInput& in = request.input;
  in.session_dir = "/srv/elsewhere/s";
  in.session_name = "s";
  in.frames.push_back({.path = "captures/1/left/stereo/exp_0.01.png",
                       .capture_kind = io::CaptureKind::kBracketedStereo,
                       .capture_id = 1,
                       .role = io::FrameRole::kStereo,
                       .view_index = 0,
                       .exposure_s = 0.01,
                       .pattern = "",
                       .inverse = false,
                       .sha256 = "ab12"});
  in.frames.push_back({.path = "captures/2/left/sl/col_b03_inv.png",
                       .capture_kind = io::CaptureKind::kStructuredLight,
                       .capture_id = 2,
                       .role = io::FrameRole::kStructuredLight,
                       .view_index = 1,
                       .exposure_s = 0.5,
                       .pattern = "col_b03",
                       .inverse = true,
                       .sha256 = "cd34"});
  in.baseline_mm = 160;
  in.projector_size = std::make_pair(128, 96);
  in.capture_summary = {{"hardware", "simulated"}, {"exposures", "1/100"}};
  in.sim_truth_disparity = "captures/1/truth/disp0.pfm";
  in.sim_truth_nonoccluded = "captures/1/truth/nonocc0.png";
  in.intrinsics =
      SessionInput::Intrinsics{.fx = 320, .fy = 321, .cx = 119.5, .cy = 89.5};
  request.steps = {"hdr", "stereo"};
  request.force = true;
  ASSERT_OK(WriteJobRequest(tmp.path(), request));

  ASSERT_OK_AND_ASSIGN(const JobRequest back,
                       ReadJobRequest(tmp.path(), "/cluster/s"));
  EXPECT_EQ(back.input.session_dir, "/cluster/s")
      << "the folder is the reader's, not the writer's";
  EXPECT_EQ(back.input.session_name, "s");
  ASSERT_EQ(back.input.frames.size(), 2u);
  const FrameInput& sl = back.input.frames[1];
  EXPECT_EQ(sl.path, "captures/2/left/sl/col_b03_inv.png");
  EXPECT_EQ(sl.capture_kind, io::CaptureKind::kStructuredLight);
  EXPECT_EQ(sl.capture_id, 2);
  EXPECT_EQ(sl.role, io::FrameRole::kStructuredLight);
  EXPECT_EQ(sl.view_index, 1);
  EXPECT_DOUBLE_EQ(sl.exposure_s, 0.5);
  EXPECT_EQ(sl.pattern, "col_b03");
  EXPECT_TRUE(sl.inverse);
  EXPECT_EQ(sl.sha256, "cd34");
  EXPECT_DOUBLE_EQ(back.input.baseline_mm, 160);
  EXPECT_EQ(back.input.projector_size, std::make_pair(128, 96));
  EXPECT_EQ(back.input.capture_summary, in.capture_summary);
  EXPECT_EQ(back.input.sim_truth_disparity, "captures/1/truth/disp0.pfm");
  EXPECT_EQ(back.input.sim_truth_nonoccluded, "captures/1/truth/nonocc0.png");
  ASSERT_TRUE(back.input.intrinsics.has_value());
  EXPECT_DOUBLE_EQ(back.input.intrinsics->fy, 321);
  EXPECT_THAT(back.steps, ::testing::ElementsAre("hdr", "stereo"));
  EXPECT_TRUE(back.force);

  TempDir empty;
  EXPECT_THAT(ReadJobRequest(empty.path(), "/s"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("request.json")));
  ASSERT_OK(
      io::WriteFileAtomically(empty / kJobRequestFile, "{\"frames\": 3}"));
  EXPECT_THAT(ReadJobRequest(empty.path(), "/s"),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("not a pipeline job request")));
}

TEST(JobFilesTest, AResultKeepsItsStatusAndStepRecords) {
  TempDir tmp;
  EXPECT_THAT(ReadJobResult(tmp.path()),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("result.json")));
  ASSERT_OK(WriteJobResult(
      tmp.path(),
      {.status = absl::OkStatus(),
       .steps = {{.step = "hdr",
                  .input_hash = "h1",
                  .computed = true,
                  .artifacts = {File("hdr/im0.pfm"), File("hdr/im1.pfm")},
                  .seconds = 2.5},
                 {.step = "response",
                  .input_hash = "h0",
                  .computed = false,
                  .artifacts = {},
                  .seconds = std::nullopt}}}));
  ASSERT_OK_AND_ASSIGN(JobResult ok, ReadJobResult(tmp.path()));
  EXPECT_OK(ok.status);
  ASSERT_EQ(ok.steps.size(), 2u);
  EXPECT_EQ(ok.steps[0].step, "hdr");
  EXPECT_EQ(ok.steps[0].input_hash, "h1");
  EXPECT_TRUE(ok.steps[0].computed);
  ASSERT_EQ(ok.steps[0].artifacts.size(), 2u);
  EXPECT_EQ(ok.steps[0].artifacts[1].sha256, "sha-hdr/im1.pfm");
  EXPECT_EQ(ok.steps[0].seconds, 2.5);
  EXPECT_FALSE(ok.steps[1].computed);
  EXPECT_EQ(ok.steps[1].seconds, std::nullopt);

  ASSERT_OK(WriteJobResult(tmp.path(), {.status = absl::FailedPreconditionError(
                                            "frame x is missing"),
                                        .steps = {}}));
  ASSERT_OK_AND_ASSIGN(JobResult failed, ReadJobResult(tmp.path()));
  EXPECT_THAT(failed.status, StatusIs(absl::StatusCode::kFailedPrecondition,
                                      "frame x is missing"));
}

TEST(JobFilesTest, FramesAndArtifactsAreCheckedAgainstTheirSha256) {
  TempDir tmp;
  ASSERT_OK(io::WriteFileAtomically(tmp / "a.png", "frame bytes"));
  ASSERT_OK_AND_ASSIGN(const std::string sha,
                       io::Sha256HexOfFile(tmp / "a.png"));
  SessionInput in;
  in.session_dir = tmp.path();
  in.frames.resize(1);
  in.frames[0].path = "a.png";
  in.frames[0].sha256 = sha;
  EXPECT_OK(VerifyFrames(in));
  in.frames[0].sha256 = std::string(64, '0');
  EXPECT_THAT(VerifyFrames(in),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("frame a.png has sha256 " + sha)));
  in.frames.emplace_back().path = "b.png";
  in.frames[0].sha256 = "";  // not recorded: only its presence is checked
  EXPECT_THAT(VerifyFrames(in), StatusIs(absl::StatusCode::kFailedPrecondition,
                                         HasSubstr("frame b.png is missing")));

  Artifact a = File("a.png");
  a.sha256 = sha;
  EXPECT_OK(VerifyArtifacts(tmp.path(), {a}));
  ASSERT_OK(io::WriteFileAtomically(tmp / "a.png", "changed on the node"));
  EXPECT_THAT(VerifyArtifacts(tmp.path(), {a}),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("artifact a.png of step hdr has sha256")));
  EXPECT_THAT(VerifyArtifacts(tmp.path(), {File("gone.pfm")}),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("artifact gone.pfm of step hdr")));
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
