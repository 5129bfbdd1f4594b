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

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "processing/io/atomic_file.h"
#include "processing/io/image.h"
#include "processing/io/sha256.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::pipeline {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;
using ::testing::StartsWith;
using json = nlohmann::json;

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

// Worse than LDR: by RMSE, against the same ground truth only; never LDR
// itself, the ground truth's own row, a NaN, or without an LDR row.
TEST(MetricsJsonTest, WorseThanLdrComparesWithinOneGroundTruth) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Metric> rows = {
      Row("ldr", "simulation", 1.0),
      Row("fattal", "simulation", 1.5),
      Row("fused", "simulation", 0.5),
      Row("drago", "simulation", 1.0),  // equal is not worse
      Row("wls", "simulation", kNaN),
      Row(kGroundTruthMethod, "simulation", 2.0),
      Row("fattal", "structured_light", 1.5),  // no LDR row here
      Row("ldr", "elsewhere", 3.0),
      Row("fused", "elsewhere", 2.0)};
  EXPECT_THAT(WorseThanLdr(rows),
              ::testing::ElementsAre(false, true, false, false, false, false,
                                     false, false, false));
  EXPECT_TRUE(WorseThanLdr({}).empty());
}

// JSON has no NaN or infinity: a metric that could not be computed (NaN)
// or an infinite one is written as null and read back as NaN, so that one
// such number does not make the whole file unreadable. Infinity does not
// come back as infinity.
TEST(MetricsJsonTest, NonFiniteMetricsComeBackAsNaN) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Metric odd = Row("ldr", "simulation", kNaN);
  odd.mae = kInf;
  odd.coverage = -kInf;
  const std::vector<Metric> rows = {odd, Row("fused", "simulation", 0.75)};
  const std::string text = MetricsToJson(rows);
  EXPECT_THAT(text, HasSubstr("\"rmse\": null"));
  EXPECT_THAT(text, HasSubstr("\"mae\": null"));
  EXPECT_THAT(text, HasSubstr("\"coverage\": null"));
  ASSERT_OK_AND_ASSIGN(const std::vector<Metric> back, MetricsFromJson(text));
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].method, "ldr");
  EXPECT_TRUE(std::isnan(back[0].rmse)) << back[0].rmse;
  EXPECT_TRUE(std::isnan(back[0].mae)) << back[0].mae;
  EXPECT_TRUE(std::isnan(back[0].coverage)) << back[0].coverage;
  EXPECT_DOUBLE_EQ(back[0].bad_1, 20);
  EXPECT_DOUBLE_EQ(back[1].rmse, 0.75);
  // Tables show them, the NaN RMSE last.
  const std::vector<Metric> sorted = SortMetrics(back);
  EXPECT_EQ(sorted[0].method, "fused");
  EXPECT_EQ(sorted[1].method, "ldr");
  EXPECT_THAT(FormatMetrics(back),
              HasSubstr("| simulation | ldr | nan | nan | 40.0 | 20.0 | "
                        "10.0 | 5.0 | nan |\n"));
  // Any other type is still refused.
  EXPECT_THAT(MetricsFromJson(R"({"metrics": [{"rmse": false}]})"),
              StatusIs(absl::StatusCode::kDataLoss,
                       "metrics.json: not a metrics file: metrics[0].rmse: "
                       "expected a number"));
}

// A pipeline state file holding such a metric opens (it used to be
// DATA_LOSS, which stopped every later run of the session).
TEST(JsonRunStoreTest, AStateFileWithNonFiniteMetricsOpens) {
  TempDir tmp;
  const auto path = tmp / "state.json";
  {
    ASSERT_OK_AND_ASSIGN(JsonRunStore store, JsonRunStore::Open(path));
    Metric odd =
        Row("ldr", "simulation", std::numeric_limits<double>::quiet_NaN());
    odd.bad_4 = std::numeric_limits<double>::infinity();
    ASSERT_OK(store.RecordMetrics({odd}));
  }
  ASSERT_OK_AND_ASSIGN(const std::string text, io::ReadFileBytes(path));
  EXPECT_THAT(text, HasSubstr("\"rmse\": null"));
  ASSERT_OK_AND_ASSIGN(JsonRunStore store, JsonRunStore::Open(path));
  ASSERT_EQ(store.metrics().size(), 1u);
  EXPECT_TRUE(std::isnan(store.metrics()[0].rmse));
  EXPECT_TRUE(std::isnan(store.metrics()[0].bad_4));
  EXPECT_DOUBLE_EQ(store.metrics()[0].coverage, 99.5);
}

// A result.json as a node writes it: one step with one artifact at `path`.
json ResultWithArtifact(const std::string& path) {
  return json{{"code", "OK"},
              {"message", ""},
              {"steps", json::array({json{{"step", "hdr"},
                                          {"input_hash", "h1"},
                                          {"computed", true},
                                          {"artifacts", json::array({json{
                                                            {"step", "hdr"},
                                                            {"kind", "hdr"},
                                                            {"path", path},
                                                            {"sha256", "ab"},
                                                            {"size_bytes", 2},
                                                        }})}}})}};
}

const char* const kOutside[] = {"../../etc/passwd", "/etc/passwd", "a/../../b"};

std::string Why(const std::string& path) {
  return path[0] == '/'
             ? absl::StrCat("path \"", path,
                            "\" is absolute (it must be relative)")
             : absl::StrCat("path \"", path, "\" has a \"..\" component");
}

// A node must not name a file outside the session folder: the result that
// does is refused as a whole, naming the field and the path, so that the
// daemon records nothing of it (RunOnSlurm fails the job with this message).
TEST(HostileSessionFilesTest, AResultNamingAPathOutsideTheSessionIsDataLoss) {
  for (const std::string path : kOutside) {
    const std::string text = ResultWithArtifact(path).dump();
    EXPECT_THAT(
        ParseJobResult(text),
        StatusIs(absl::StatusCode::kDataLoss,
                 absl::StrCat("not a pipeline job result: steps[0].artifacts[0]"
                              ".path: ",
                              Why(path))));
    TempDir tmp;
    ASSERT_OK(io::WriteFileAtomically(tmp / kJobResultFile, text));
    EXPECT_THAT(ReadJobResult(tmp.path()),
                StatusIs(absl::StatusCode::kDataLoss,
                         absl::StrCat((tmp / kJobResultFile).string(),
                                      ": not a pipeline job result: "
                                      "steps[0].artifacts[0].path: ",
                                      Why(path))));
  }
  // The same result inside the session is read.
  ASSERT_OK_AND_ASSIGN(
      const JobResult ok,
      ParseJobResult(ResultWithArtifact("hdr/im0.pfm").dump()));
  ASSERT_EQ(ok.steps.size(), 1u);
  EXPECT_EQ(ok.steps[0].artifacts[0].path, "hdr/im0.pfm");
}

TEST(HostileSessionFilesTest, AStateFileNamingAPathOutsideTheSessionIsRefused) {
  for (const std::string path : kOutside) {
    const json state{
        {"steps",
         {{"hdr",
           {{"input_hash", "h1"},
            {"artifacts", json::array({json{{"path", "hdr/im0.pfm"}},
                                       json{{"path", path}}})}}}}},
        {"metrics", json::array()}};
    EXPECT_THAT(JsonRunStore::Parse(state.dump(), "/s/pipeline_state.json"),
                StatusIs(absl::StatusCode::kDataLoss,
                         absl::StrCat("not a pipeline state file: "
                                      "steps[\"hdr\"].artifacts[1].path: ",
                                      Why(path))));
    TempDir tmp;
    const std::filesystem::path file = tmp / "pipeline_state.json";
    ASSERT_OK(io::WriteFileAtomically(file, state.dump()));
    EXPECT_THAT(
        JsonRunStore::Open(file),
        StatusIs(absl::StatusCode::kDataLoss,
                 StartsWith(file.string() + ": not a pipeline state file: ")));
    // Refused, not rewritten.
    ASSERT_OK_AND_ASSIGN(const std::string kept, io::ReadFileBytes(file));
    EXPECT_EQ(kept, state.dump());
  }
  ASSERT_OK_AND_ASSIGN(
      const JsonRunStore store,
      JsonRunStore::Parse(R"({"steps": {"hdr": {"input_hash": "h1",
          "artifacts": [{"path": "hdr/im0.pfm"}]}}})",
                          "/s/pipeline_state.json"));
  EXPECT_THAT(store.StepNames(), ::testing::ElementsAre("hdr"));
  EXPECT_EQ(store.Entry("hdr")->second[0].path, "hdr/im0.pfm");
}

// request.json is the daemon's, read back on the node: its frame and truth
// paths are checked alike.
TEST(HostileSessionFilesTest, ARequestNamingAPathOutsideTheSessionIsRefused) {
  JobRequest request;
  request.input.session_name = "s";
  request.input.frames.emplace_back().path = "captures/1/left/stereo/e.png";
  request.steps = {"hdr"};
  TempDir tmp;
  ASSERT_OK(WriteJobRequest(tmp.path(), request));
  ASSERT_OK_AND_ASSIGN(std::string text,
                       io::ReadFileBytes(tmp / kJobRequestFile));
  const json good = json::parse(text);
  ASSERT_OK(ParseJobRequest(text, "/s").status());
  for (const std::string path : kOutside) {
    json frame = good;
    frame["frames"][0]["path"] = path;
    EXPECT_THAT(ParseJobRequest(frame.dump(), "/s"),
                StatusIs(absl::StatusCode::kDataLoss,
                         absl::StrCat("not a pipeline job request: frames[0]"
                                      ".path: ",
                                      Why(path))));
    json truth = good;
    truth["sim_truth_disparity"] = path;
    EXPECT_THAT(ParseJobRequest(truth.dump(), "/s"),
                StatusIs(absl::StatusCode::kDataLoss,
                         absl::StrCat("not a pipeline job request: "
                                      "sim_truth_disparity: ",
                                      Why(path))));
  }
  ASSERT_OK(io::WriteFileAtomically(tmp / kJobRequestFile, [&] {
    json j = good;
    j["frames"][0]["path"] = "/etc/shadow";
    return j.dump();
  }()));
  EXPECT_THAT(
      ReadJobRequest(tmp.path(), "/s"),
      StatusIs(absl::StatusCode::kDataLoss,
               HasSubstr(": not a pipeline job request: frames[0].path: "
                         "path \"/etc/shadow\" is absolute (it must be "
                         "relative)")));
}

// Every field of its JSON type and within its limit, the field named.
TEST(HostileSessionFilesTest, WrongTypesAndSizesNameTheField) {
  const json result = ResultWithArtifact("hdr/im0.pfm");
  auto result_with = [&](const json::json_pointer& at, const json& value) {
    json j = result;
    j[at] = value;
    return ParseJobResult(j.dump());
  };
  const std::pair<absl::StatusOr<JobResult>, std::string> results[] = {
      {result_with("/code"_json_pointer, 3), "code: expected a string"},
      {result_with("/steps"_json_pointer, json::object()),
       "steps: expected an array"},
      {result_with("/steps/0/computed"_json_pointer, "yes"),
       "steps[0].computed: expected true or false"},
      {result_with("/steps/0/artifacts/0/size_bytes"_json_pointer, "big"),
       "steps[0].artifacts[0].size_bytes: expected an integer"},
      {result_with("/steps/0/artifacts/0/size_bytes"_json_pointer, -1),
       "steps[0].artifacts[0].size_bytes: -1 is outside [0, "},
      {result_with("/steps/0/artifacts/0/path"_json_pointer, json()),
       "steps[0].artifacts[0].path: expected a string"},
      {result_with("/steps/0/seconds"_json_pointer, "slow"),
       "steps[0].seconds: expected a number"},
      {result_with("/steps/0"_json_pointer, 7), "steps[0]: expected an object"},
      {result_with("/steps"_json_pointer, json(std::vector<int>(257, 1))),
       "steps: 257 elements, more than the limit of 256"},
      {result_with("/message"_json_pointer, std::string(70000, 'm')),
       "message: \"mmmm"},
      {ParseJobResult("[]"), "not a pipeline job result: not an object"},
      {ParseJobResult("{\"code\": \"" + std::string(100000, 'c')),
       "not a pipeline job result: [json.exception.parse_error.101]"},
  };
  for (const auto& [parsed, message] : results) {
    EXPECT_THAT(parsed,
                StatusIs(absl::StatusCode::kDataLoss, HasSubstr(message)));
    EXPECT_LT(parsed.status().message().size(), 400u) << message;
  }

  JobRequest request;
  request.input.session_name = "s";
  request.input.frames.emplace_back().path = "captures/1/left/stereo/e.png";
  request.input.projector_size = std::make_pair(1024, 768);
  TempDir tmp;
  ASSERT_OK(WriteJobRequest(tmp.path(), request));
  ASSERT_OK_AND_ASSIGN(const std::string text,
                       io::ReadFileBytes(tmp / kJobRequestFile));
  const json good = json::parse(text);
  auto request_with = [&](const json::json_pointer& at, const json& value) {
    json j = good;
    j[at] = value;
    return ParseJobRequest(j.dump(), "/s");
  };
  const std::pair<absl::StatusOr<JobRequest>, std::string> requests[] = {
      {request_with("/frames/0/view_index"_json_pointer, 99),
       "frames[0].view_index: 99 is outside [0, 15]"},
      {request_with("/frames/0/capture_id"_json_pointer,
                    json::parse("18446744073709551615")),
       "frames[0].capture_id: 18446744073709551615 is outside [0, "},
      {request_with("/frames/0/role"_json_pointer, "lunch"),
       "frames[0].role: "},
      {request_with("/frames/0"_json_pointer, 1),
       "frames[0]: expected an object"},
      {request_with("/frames"_json_pointer,
                    json(std::vector<json>(100001, json::object()))),
       "frames: 100001 elements, more than the limit of 100000"},
      {request_with("/projector_size"_json_pointer, json::array({0, 5})),
       "projector_size[0]: 0 is outside [1, 16384]"},
      {request_with("/projector_size"_json_pointer, json::array({5})),
       "projector_size: expected [width, height]"},
      {request_with("/capture_summary"_json_pointer,
                    json::array({json::array({"a"})})),
       "capture_summary[0]: expected [key, value]"},
      {request_with("/capture_summary"_json_pointer,
                    json::array({json::array({"a", 1})})),
       "capture_summary[0][1]: expected a string"},
      {request_with("/steps"_json_pointer, "hdr"), "steps: expected an array"},
      {request_with("/force"_json_pointer, 1), "force: expected true or false"},
      {request_with("/baseline_mm"_json_pointer, "far"),
       "baseline_mm: expected a number"},
  };
  for (const auto& [parsed, message] : requests) {
    EXPECT_THAT(parsed,
                StatusIs(absl::StatusCode::kDataLoss,
                         HasSubstr(absl::StrCat("not a pipeline job request: ",
                                                message))));
  }

  const std::pair<std::string, std::string> states[] = {
      {R"({"steps": []})", "steps: expected an object"},
      {R"({"steps": {"hdr": {"artifacts": 5}}})",
       "steps[\"hdr\"].artifacts: expected an array"},
      {R"({"steps": {"hdr": {"input_hash": 5}}})",
       "steps[\"hdr\"].input_hash: expected a string"},
      {R"({"metrics": [{"rmse": "low"}]})",
       "metrics[0].rmse: expected a number"},
  };
  for (const auto& [state, message] : states) {
    EXPECT_THAT(JsonRunStore::Parse(state, "/s/state.json"),
                StatusIs(absl::StatusCode::kDataLoss,
                         absl::StrCat("not a pipeline state file: ", message)));
  }
  EXPECT_THAT(MetricsFromJson(R"({"metrics": [{"coverage": [1]}]})"),
              StatusIs(absl::StatusCode::kDataLoss,
                       "metrics.json: not a metrics file: metrics[0].coverage: "
                       "expected a number"));
}

// A file too large to be one is refused before it is read.
// Refused by the file's size before it is read (a sparse file: no disk
// used), not by the parser's check of the text.
TEST(HostileSessionFilesTest, AHugeResultFileIsRefusedUnread) {
  TempDir tmp;
  const std::filesystem::path file = tmp / kJobResultFile;
  ASSERT_OK(io::WriteFileAtomically(file, "{"));
  std::filesystem::resize_file(file, (size_t{64} << 20) + 1);
  EXPECT_THAT(
      ReadJobResult(tmp.path()),
      StatusIs(absl::StatusCode::kDataLoss,
               file.string() + ": pipeline job result of 67108865 bytes, more "
                               "than the limit of 67108864; not read"));
}

// A metrics file that a node names (or the evaluate step wrote) is read as
// the other files are: bounded before it is read, named in its errors.
TEST(HostileSessionFilesTest, AMetricsFileIsReadBoundedAndNamed) {
  TempDir tmp;
  const std::filesystem::path file = tmp / "metrics.json";
  ASSERT_OK(io::WriteFileAtomically(
      file, MetricsToJson({Row("fused", "simulation", 0.75)})));
  ASSERT_OK_AND_ASSIGN(const std::vector<Metric> rows, ReadMetricsFile(file));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_DOUBLE_EQ(rows[0].rmse, 0.75);

  ASSERT_OK(io::WriteFileAtomically(file, R"({"metrics": [{"rmse": "x"}]})"));
  EXPECT_THAT(ReadMetricsFile(file),
              StatusIs(absl::StatusCode::kDataLoss,
                       file.string() +
                           ": not a metrics file: metrics[0].rmse: expected a "
                           "number"));
  std::filesystem::resize_file(file, (size_t{64} << 20) + 1);
  EXPECT_THAT(ReadMetricsFile(file),
              StatusIs(absl::StatusCode::kDataLoss,
                       file.string() +
                           ": metrics file of 67108865 bytes, more than the "
                           "limit of 67108864; not read"));
  EXPECT_THAT(ReadMetricsFile(tmp / "none.json"),
              StatusIs(absl::StatusCode::kNotFound,
                       (tmp / "none.json").string() + ": no metrics file"));
}

}  // namespace
}  // namespace hdrstereo::pipeline
