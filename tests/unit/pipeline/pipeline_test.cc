// SPDX-License-Identifier: GPL-3.0-or-later
//
// The session pipeline on a simulated lab-lamp session (240 x 180 camera,
// 256 x 192 projector, five exposures, structured light at 1/30 and 1/125 s,
// exact truth): step resolution, the files of a full run, metrics against
// both ground truths, reuse / partial recomputation / force, the step
// options as the cache key (on a smaller session), bad input, the
// Middlebury export, the command-line tool and the HTML report in headless
// Chromium. The full run is done once; tests that change things work on
// copies of its folder and store.
#include "processing/pipeline/pipeline.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "processing/io/atomic_file.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/io/sha256.h"
#include "processing/pipeline/session_files.h"
#include "processing/tonemap/tonemap.h"
#include "tests/support/proc_tool.h"
#include "tests/support/sim_session.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::pipeline {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::TempDir;

class MemoryStore : public RunStore {
 public:
  std::vector<Artifact> Lookup(const std::string& step,
                               const std::string& input_hash) override {
    auto it = steps.find(step);
    if (it == steps.end() || it->second.first != input_hash) return {};
    return it->second.second;
  }
  absl::Status Record(const std::string& step, const std::string& input_hash,
                      const std::vector<Artifact>& artifacts) override {
    steps[step] = {input_hash, artifacts};
    return absl::OkStatus();
  }
  absl::Status RecordMetrics(const std::vector<Metric>& m) override {
    metrics = m;
    ++metrics_calls;
    return absl::OkStatus();
  }
  std::map<std::string, std::pair<std::string, std::vector<Artifact>>> steps;
  std::vector<Metric> metrics;
  int metrics_calls = 0;
};

class Recorder : public RunObserver {
 public:
  absl::Status Checkpoint() override {
    ++checkpoints;
    return cancel_after >= 0 && checkpoints > cancel_after
               ? absl::CancelledError("cancelled by the test")
               : absl::OkStatus();
  }
  void Progress(int64_t, int64_t, const std::string& what) override {
    progress.push_back(what);
  }
  void Info(const std::string& message) override { infos.push_back(message); }
  void Warn(const std::string& message) override {
    warnings.push_back(message);
  }
  void StepComputed(const std::string& step, absl::Duration took) override {
    step_times[step].push_back(took);
  }
  bool Warned(const std::string& part) const {
    for (const std::string& w : warnings) {
      if (absl::StrContains(w, part)) return true;
    }
    return false;
  }
  int cancel_after = -1;
  int checkpoints = 0;
  std::vector<std::string> progress;
  std::vector<std::string> infos;
  std::vector<std::string> warnings;
  std::map<std::string, std::vector<absl::Duration>> step_times;
};

// The steps whose time `recorder` was told, once each and not negative.
std::vector<std::string> TimedSteps(const Recorder& recorder) {
  std::vector<std::string> steps;
  for (const auto& [step, times] : recorder.step_times) {
    EXPECT_EQ(times.size(), 1u) << step;
    for (absl::Duration took : times) {
      EXPECT_GE(took, absl::ZeroDuration()) << step;
    }
    steps.push_back(step);
  }
  return steps;
}

std::vector<std::string> Methods() {
  std::vector<std::string> m = {"ldr"};
  for (tonemap::Operator op : tonemap::AllOperators()) {
    m.push_back(tonemap::OperatorName(op));
  }
  for (const char* n : {"hdr", "mean", "median", "fused"}) m.push_back(n);
  return m;
}

const Metric* Find(const std::vector<Metric>& rows, const std::string& gt,
                   const std::string& method) {
  for (const Metric& m : rows) {
    if (m.ground_truth == gt && m.method == method) return &m;
  }
  return nullptr;
}

SessionInput Discover(const fs::path& dir) {
  absl::StatusOr<SessionInput> in = DiscoverSession(dir);
  EXPECT_TRUE(in.ok()) << in.status();
  return in.ok() ? *in : SessionInput();
}

// One processed session shared by the tests.
struct Processed {
  TempDir tmp;
  fs::path dir;
  MemoryStore store;
  RunSummary summary;
  Recorder recorder;
  absl::Status status;
};

const Processed& Shared() {
  // Destroyed at exit, which removes its folder.
  static Processed processed;
  static Processed* p = [] {
    Processed* out = &processed;
    out->dir = out->tmp / "session";
    out->status = testing::CopyCachedSimSession(out->dir);
    if (!out->status.ok()) return out;
    RunOptions o;
    o.threads = 2;
    absl::StatusOr<RunSummary> s =
        Run(Discover(out->dir), o, out->store, out->recorder);
    out->status = s.status();
    if (s.ok()) out->summary = *s;
    return out;
  }();
  return *p;
}

// A copy of the processed session and its store.
struct Copy {
  TempDir tmp;
  fs::path dir;
  MemoryStore store;
};

std::unique_ptr<Copy> CopyProcessed() {
  const Processed& p = Shared();
  auto c = std::make_unique<Copy>();
  c->dir = c->tmp / "session";
  fs::copy(p.dir, c->dir, fs::copy_options::recursive);
  c->store = p.store;
  return c;
}

std::set<std::string> AsSet(const std::vector<std::string>& v) {
  return {v.begin(), v.end()};
}

TEST(PipelineStepsTest, SubsetsAddTheirDependencies) {
  absl::StatusOr<std::vector<std::string>> s = ResolveSteps({"tonemap", "hdr"});
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(*s, (std::vector<std::string>{"decode", "rectify", "response",
                                          "hdr", "tonemap"}));
  s = ResolveSteps({"sl_groundtruth"});
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(*s, std::vector<std::string>{"sl_groundtruth"});
  s = ResolveSteps({"evaluate"});
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(AsSet(*s), (std::set<std::string>{
                           "decode", "rectify", "response", "hdr", "tonemap",
                           "sl_groundtruth", "stereo", "fusion", "evaluate"}));
  s = ResolveSteps({});
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(*s, AllSteps());
  EXPECT_EQ(AllSteps().size(), 11u);
  // Topological: every dependency comes earlier.
  for (size_t i = 0; i < AllSteps().size(); ++i) {
    for (const std::string& d : StepDependencies(AllSteps()[i])) {
      const auto at = std::find(AllSteps().begin(), AllSteps().end(), d);
      ASSERT_NE(at, AllSteps().end()) << d;
      EXPECT_LT(static_cast<size_t>(at - AllSteps().begin()), i);
    }
  }
}

TEST(PipelineStepsTest, UnknownStepListsKnownOnes) {
  absl::StatusOr<std::vector<std::string>> s =
      ResolveSteps({"hdr", "tonemapping"});
  ASSERT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StrContains(s.status().message(), "tonemapping"));
  for (const std::string& step : AllSteps()) {
    EXPECT_TRUE(absl::StrContains(s.status().message(), step)) << step;
  }
  // Run says the same, before touching anything.
  TempDir tmp;
  MemoryStore store;
  Recorder rec;
  SessionInput in;
  in.session_dir = tmp.path();
  RunOptions o;
  o.steps = {"nope"};
  EXPECT_EQ(pipeline::Run(in, o, store, rec).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(fs::is_empty(tmp.path()));
}

void FindsFramesTruthAndIntrinsics() {
  TempDir tmp;
  ASSERT_TRUE(testing::CopyCachedSimSession(tmp / "s").ok());
  const SessionInput in = Discover(tmp / "s");
  int stereo = 0, ambient = 0, sl = 0;
  for (const FrameInput& f : in.frames) {
    EXPECT_TRUE(fs::exists(in.session_dir / f.path)) << f.path;
    if (f.role == io::FrameRole::kStereo) {
      ++stereo;
      EXPECT_EQ(f.capture_kind, io::CaptureKind::kBracketedStereo);
      EXPECT_EQ(f.capture_id, 1);
      EXPECT_GT(f.exposure_s, 0);
    } else if (f.role == io::FrameRole::kAmbient) {
      ++ambient;
    } else if (f.role == io::FrameRole::kStructuredLight) {
      ++sl;
      EXPECT_EQ(f.capture_id, 2);
      EXPECT_FALSE(f.pattern.empty());
    }
  }
  EXPECT_EQ(stereo, 10);  // 5 exposures x 2 views
  EXPECT_EQ(ambient, 1);
  // 256 x 192: 8 + 8 bit planes, each with its inverse, white, black;
  // 2 exposures, 2 views.
  EXPECT_EQ(sl, (2 * 16 + 2) * 2 * 2);
  EXPECT_EQ(in.sim_truth_disparity, "captures/1/truth/disp0.pfm");
  EXPECT_EQ(in.sim_truth_nonoccluded, "captures/1/truth/nonocc0.png");
  EXPECT_DOUBLE_EQ(in.baseline_mm, 150);
  ASSERT_TRUE(in.intrinsics.has_value());
  EXPECT_DOUBLE_EQ(in.intrinsics->cx, (240 - 1) / 2.0);
  EXPECT_GT(in.intrinsics->fx, 100);
}

void FullRunWritesEveryFileWithItsRecordedHash() {
  const Processed& p = Shared();
  ASSERT_TRUE(p.status.ok()) << p.status;
  EXPECT_EQ(p.summary.computed, AllSteps());
  EXPECT_TRUE(p.summary.reused.empty());
  EXPECT_EQ(AsSet(TimedSteps(p.recorder)), AsSet(AllSteps()));
  EXPECT_EQ(p.summary.report_path, "report/index.html");
  std::vector<std::string> expected = {
      "decoded/left/exposures.txt",
      "exposures/left/exposures.txt",
      "exposures/right/exp_1-250s.png",
      "hdr/response.yml",
      "hdr/im0.pfm",
      "hdr/im1.pfm",
      "ground_truth/structured_light/disp0GT.pfm",
      "ground_truth/structured_light/mask0nocc.png",
      "metrics/metrics.json",
      "im0.png",
      "im1.png",
      "disp0GT.pfm",
      "mask0nocc.png",
      "calib.txt",
      "report/index.html"};
  for (tonemap::Operator op : tonemap::AllOperators()) {
    for (const char* v : {"im0.png", "im1.png"}) {
      expected.push_back(
          absl::StrCat("tonemapped/", tonemap::OperatorName(op), "/", v));
    }
  }
  for (const std::string& m : Methods()) {
    expected.push_back(absl::StrCat("disparity/", m, ".pfm"));
  }
  std::set<std::string> recorded;
  for (const auto& [step, entry] : p.store.steps) {
    ASSERT_FALSE(entry.second.empty()) << step;
    for (const Artifact& a : entry.second) {
      EXPECT_EQ(a.step, step);
      absl::StatusOr<std::string> sha = io::Sha256HexOfFile(p.dir / a.path);
      ASSERT_TRUE(sha.ok()) << a.path;
      EXPECT_EQ(*sha, a.sha256) << a.path;
      EXPECT_EQ(static_cast<int64_t>(fs::file_size(p.dir / a.path)),
                a.size_bytes);
      recorded.insert(a.path);
    }
  }
  EXPECT_EQ(p.store.steps.size(), AllSteps().size());
  for (const std::string& f : expected) {
    EXPECT_TRUE(recorded.count(f)) << f << " not recorded";
    EXPECT_TRUE(fs::exists(p.dir / f)) << f;
  }
  // Progress: one line per matching among others.
  int stereo_units = 0;
  for (const std::string& what : p.recorder.progress) {
    if (absl::StartsWith(what, "stereo: ")) ++stereo_units;
  }
  EXPECT_EQ(stereo_units, 9);
}

void MetricsAgainstSimulatorAndStructuredLight() {
  const Processed& p = Shared();
  ASSERT_TRUE(p.status.ok()) << p.status;
  EXPECT_EQ(p.store.metrics_calls, 1);
  // Every method against both truths, and the structured-light truth
  // itself against the exact one.
  EXPECT_EQ(p.summary.metrics.size(), 2 * Methods().size() + 1);
  const Metric* sl = Find(p.summary.metrics, "simulation", kGroundTruthMethod);
  ASSERT_NE(sl, nullptr);
  EXPECT_LT(sl->rmse, 0.5);       // measured 0.398
  EXPECT_GT(sl->coverage, 80.0);  // measured 87.1 %
  for (const char* gt : {"simulation", "structured_light"}) {
    for (const std::string& m : Methods()) {
      const Metric* row = Find(p.summary.metrics, gt, m);
      ASSERT_NE(row, nullptr) << gt << " " << m;
      EXPECT_TRUE(std::isfinite(row->rmse));
      EXPECT_GE(row->bad_0_5, row->bad_1);
      EXPECT_GE(row->bad_1, row->bad_2);
      EXPECT_GE(row->bad_2, row->bad_4);
      EXPECT_GT(row->coverage, 90.0) << gt << " " << m;
    }
  }
  std::cout << FormatMetrics(p.summary.metrics);
  const Metric* fused = Find(p.summary.metrics, "simulation", "fused");
  const Metric* ldr = Find(p.summary.metrics, "simulation", "ldr");
  ASSERT_NE(fused, nullptr);
  ASSERT_NE(ldr, nullptr);
  ::testing::Test::RecordProperty("fused_rmse", std::to_string(fused->rmse));
  ::testing::Test::RecordProperty("ldr_rmse", std::to_string(ldr->rmse));
  // Fusion of the seven tone-mapped matchings beats matching the middle
  // exposure alone on lab-lamp (the thesis' claim, Table 5.2).
  EXPECT_LT(fused->rmse, 0.9 * ldr->rmse);
  // The structured-light truth agrees with the exact truth, so scores
  // against either tell the same story for the fused map (within 1 px).
  const Metric* fused_sl = Find(p.summary.metrics, "structured_light", "fused");
  ASSERT_NE(fused_sl, nullptr);
  EXPECT_LT(std::abs(fused_sl->rmse - fused->rmse), 1.0);
}

void SecondRunRecomputesNothing() {
  std::unique_ptr<Copy> c = CopyProcessed();
  Recorder rec;
  absl::StatusOr<RunSummary> s =
      pipeline::Run(Discover(c->dir), {}, c->store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_TRUE(s->computed.empty()) << ::testing::PrintToString(s->computed);
  EXPECT_TRUE(rec.step_times.empty());  // a reused step took no time
  EXPECT_EQ(s->reused, AllSteps());
  EXPECT_EQ(s->metrics.size(), 2 * Methods().size() + 1);
  EXPECT_EQ(c->store.metrics_calls, 1);  // from the first run only
}

void DeletedArtifactRecomputesOnlyItsStep() {
  std::unique_ptr<Copy> c = CopyProcessed();
  fs::remove(c->dir / "tonemapped/drago/im1.png");
  fs::remove(c->dir / "disparity/fused.pfm");
  Recorder rec;
  absl::StatusOr<RunSummary> s =
      pipeline::Run(Discover(c->dir), {}, c->store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  // Deterministic outputs: the recomputed files are byte-identical, so
  // nothing downstream of them is recomputed.
  EXPECT_EQ(s->computed, (std::vector<std::string>{"tonemap", "fusion"}));
  EXPECT_EQ(TimedSteps(rec), (std::vector<std::string>{"fusion", "tonemap"}));
  EXPECT_TRUE(fs::exists(c->dir / "tonemapped/drago/im1.png"));
  EXPECT_TRUE(fs::exists(c->dir / "disparity/fused.pfm"));
}

void ChangedArtifactRecomputesItsDependents() {
  std::unique_ptr<Copy> c = CopyProcessed();
  // A different tone-mapped image (not what tonemap would write) recorded
  // as if tonemap had produced it: stereo's inputs change.
  cv::Mat image = cv::imread((c->dir / "tonemapped/drago/im1.png").string());
  ASSERT_FALSE(image.empty());
  image = cv::Scalar::all(255) - image;
  ASSERT_TRUE(io::WritePng(c->dir / "tonemapped/drago/im1.png", image).ok());
  for (Artifact& a : c->store.steps["tonemap"].second) {
    if (a.path == "tonemapped/drago/im1.png") {
      a.sha256 = *io::Sha256HexOfFile(c->dir / a.path);
    }
  }
  Recorder rec;
  RunOptions o;
  o.steps = {"stereo"};
  absl::StatusOr<RunSummary> s =
      pipeline::Run(Discover(c->dir), o, c->store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->computed, std::vector<std::string>{"stereo"});
  EXPECT_EQ(AsSet(s->reused),
            (std::set<std::string>{"decode", "rectify", "response", "hdr",
                                   "tonemap", "sl_groundtruth"}));
}

void ForceRecomputesEverything() {
  std::unique_ptr<Copy> c = CopyProcessed();
  Recorder rec;
  RunOptions o;
  o.force = true;
  o.steps = {"export"};
  absl::StatusOr<RunSummary> s =
      pipeline::Run(Discover(c->dir), o, c->store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->computed, (std::vector<std::string>{
                             "decode", "rectify", "sl_groundtruth", "export"}));
  EXPECT_TRUE(s->reused.empty());
  // Everything again on one thread: the same bytes as the first run's two
  // threads (outputs do not depend on the thread split).
  o.steps.clear();
  o.threads = 1;
  s = pipeline::Run(Discover(c->dir), o, c->store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->computed, AllSteps());
  for (const auto& [step, entry] : Shared().store.steps) {
    EXPECT_EQ(c->store.steps.at(step).first, entry.first) << step;
    ASSERT_EQ(c->store.steps.at(step).second.size(), entry.second.size());
    for (size_t i = 0; i < entry.second.size(); ++i) {
      EXPECT_EQ(c->store.steps.at(step).second[i].sha256,
                entry.second[i].sha256)
          << entry.second[i].path;
    }
  }
}

void NoFramesIsFailedPrecondition() {
  TempDir tmp;
  MemoryStore store;
  Recorder rec;
  absl::StatusOr<RunSummary> s =
      pipeline::Run(Discover(tmp.path()), {}, store, rec);
  ASSERT_EQ(s.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_TRUE(absl::StrContains(s.status().message(), "no frames"));
  EXPECT_TRUE(store.steps.empty());
}

void MissingBitPlaneIsFailedPreconditionAndKeepsOutputs() {
  TempDir tmp;
  const fs::path dir = tmp / "session";
  ASSERT_TRUE(testing::CopyCachedSimSession(dir).ok());
  MemoryStore store;
  Recorder rec;
  RunOptions o;
  o.steps = {"sl_groundtruth"};
  ASSERT_TRUE(pipeline::Run(Discover(dir), o, store, rec).ok());
  fs::remove(dir /
             "captures/2/left/structured_light/sl_col_b03_inv_exp_1-30s.png");
  const MemoryStore before = store;
  o.steps.clear();
  o.force = true;
  absl::StatusOr<RunSummary> s = pipeline::Run(Discover(dir), o, store, rec);
  ASSERT_EQ(s.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_TRUE(absl::StrContains(s.status().message(), "col_b03_inv"))
      << s.status();
  EXPECT_TRUE(absl::StrContains(s.status().message(), "1-30s"));
  // Nothing recorded, nothing rewritten or deleted.
  ASSERT_EQ(store.steps.size(), 1u);
  for (const auto& [step, entry] : before.steps) {
    EXPECT_EQ(store.steps.at(step).first, entry.first) << step;
    for (const Artifact& a : entry.second) {
      absl::StatusOr<std::string> sha = io::Sha256HexOfFile(dir / a.path);
      ASSERT_TRUE(sha.ok()) << a.path;
      EXPECT_EQ(*sha, a.sha256) << a.path;
    }
  }
  EXPECT_EQ(before.steps.at("sl_groundtruth").second.size(), 5u);
}

void NoGroundTruthWarnsAndWritesNoMetrics() {
  TempDir tmp;
  const fs::path dir = tmp / "session";
  ASSERT_TRUE(testing::CopyCachedSimSession(dir).ok());
  SessionInput in = Discover(dir);
  in.sim_truth_disparity.clear();
  in.sim_truth_nonoccluded.clear();
  in.intrinsics.reset();
  std::vector<FrameInput> frames;
  for (const FrameInput& f : in.frames) {
    if (f.capture_kind != io::CaptureKind::kStructuredLight) {
      frames.push_back(f);
    }
  }
  in.frames = frames;
  MemoryStore store;
  Recorder rec;
  RunOptions o;
  o.steps = {"evaluate", "export"};
  absl::StatusOr<RunSummary> s = pipeline::Run(in, o, store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_TRUE(s->metrics.empty());
  EXPECT_EQ(store.metrics_calls, 1);
  EXPECT_TRUE(store.metrics.empty());
  EXPECT_TRUE(rec.Warned("no structured-light capture"));
  EXPECT_TRUE(rec.Warned("no ground truth"));
  EXPECT_TRUE(rec.Warned("intrinsics unknown"));
  EXPECT_TRUE(fs::exists(dir / "calib.txt"));
  EXPECT_FALSE(fs::exists(dir / "disp0GT.pfm"));
}

void CancelStopsTheRun() {
  std::unique_ptr<Copy> c = CopyProcessed();
  Recorder rec;
  rec.cancel_after = 3;
  RunOptions o;
  o.force = true;
  absl::StatusOr<RunSummary> s =
      pipeline::Run(Discover(c->dir), o, c->store, rec);
  EXPECT_EQ(s.status().code(), absl::StatusCode::kCancelled);
}

void MiddleburyExportIsReadable() {
  const Processed& p = Shared();
  ASSERT_TRUE(p.status.ok()) << p.status;
  const cv::Mat im0 = cv::imread((p.dir / "im0.png").string());
  const cv::Mat im1 = cv::imread((p.dir / "im1.png").string());
  ASSERT_FALSE(im0.empty());
  EXPECT_EQ(im0.size(), cv::Size(240, 180));
  EXPECT_EQ(im1.size(), im0.size());
  absl::StatusOr<cv::Mat> gt = io::ReadPfm(p.dir / "disp0GT.pfm");
  ASSERT_TRUE(gt.ok()) << gt.status();
  const cv::Mat mask =
      cv::imread((p.dir / "mask0nocc.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(mask.size(), gt->size());
  int nonocc = 0;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      const uint8_t m = mask.at<uint8_t>(y, x);
      EXPECT_TRUE(m == 0 || m == 128 || m == 255);
      if (m == 255) {
        ++nonocc;
        EXPECT_TRUE(std::isfinite(gt->at<float>(y, x))) << x << "," << y;
      }
    }
  }
  // The structured-light truth covers most of the lit scene.
  EXPECT_GT(nonocc, mask.rows * mask.cols / 2);
  absl::StatusOr<std::string> calib = io::ReadFileBytes(p.dir / "calib.txt");
  ASSERT_TRUE(calib.ok());
  for (const char* key : {"cam0=[", "cam1=[", "doffs=0\n", "baseline=150\n",
                          "width=240\n", "height=180\n", "ndisp="}) {
    EXPECT_TRUE(absl::StrContains(*calib, key)) << key << " in " << *calib;
  }
}

void RunsAndReusesThroughTheStateFile() {
  std::unique_ptr<Copy> c = CopyProcessed();
  const std::string dir = c->dir.string();
  testing::CommandResult r = testing::Proc(
      {"pipeline", "--session-dir", dir, "--steps", "export,evaluate"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(c->dir / "pipeline_state.json"));
  EXPECT_TRUE(absl::StrContains(r.out, "| structured_light | fused |"))
      << r.out;
  EXPECT_TRUE(absl::StrContains(r.err, "computed: decode")) << r.err;
  r = testing::Proc(
      {"pipeline", "--session-dir", dir, "--steps", "export,evaluate"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(absl::StrContains(r.err, "computed: \n")) << r.err;
  r = testing::Proc({"pipeline", "--session-dir", dir, "--steps", "bogus"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(absl::StrContains(r.err, "known steps")) << r.err;
}

// The report in headless Chromium: every image decodes, the metrics table
// is there, and a screenshot is saved (and not blank).
void LoadsInHeadlessChromium() {
  const Processed& p = Shared();
  ASSERT_TRUE(p.status.ok()) << p.status;
  const fs::path page = p.dir / "report/index.html";
  ASSERT_TRUE(fs::exists(page));
  ASSERT_TRUE(fs::exists("/usr/bin/chromium"))
      << "chromium missing: run deploy/setup-deps.sh";
  TempDir profile;
  const std::vector<std::string> common = {
      "/usr/bin/chromium",
      "--headless",
      "--no-sandbox",
      "--disable-gpu",
      "--disable-dev-shm-usage",
      "--no-first-run",
      absl::StrCat("--user-data-dir=", (profile / "p").string()),
      "--virtual-time-budget=10000"};
  std::vector<std::string> dump = common;
  dump.push_back("--dump-dom");
  dump.push_back(absl::StrCat("file://", page.string()));
  absl::StatusOr<testing::CommandResult> r =
      testing::RunCommand(dump, absl::Seconds(120));
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->exit_code, 0) << r->err;
  const std::string& dom = r->out;
  int images = 0;
  for (size_t at = dom.find("<img"); at != std::string::npos;
       at = dom.find("<img", at + 1)) {
    ++images;
  }
  // Exposures (2 x 5), preview, 7 pairs, 2 truths with masks, 12
  // disparities, 12 x 2 error maps.
  EXPECT_EQ(images, 10 + 1 + 14 + 4 + 12 + 24);
  EXPECT_TRUE(absl::StrContains(
      dom, absl::StrCat("data-images-loaded=\"", images, "/", images, "\"")))
      << dom.substr(0, 2000);
  EXPECT_TRUE(absl::StrContains(dom, "<table id=\"metrics\">"));
  EXPECT_TRUE(absl::StrContains(dom, "<td>fused</td>"));

  const fs::path shot = profile / "report.png";
  std::vector<std::string> screenshot = common;
  screenshot.push_back(absl::StrCat("--screenshot=", shot.string()));
  screenshot.push_back("--window-size=1280,3000");
  screenshot.push_back(absl::StrCat("file://", page.string()));
  r = testing::RunCommand(screenshot, absl::Seconds(120));
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->exit_code, 0) << r->err;
  const cv::Mat png = cv::imread(shot.string());
  ASSERT_FALSE(png.empty());
  EXPECT_EQ(png.cols, 1280);
  cv::Scalar mean, stddev;
  cv::meanStdDev(png, mean, stddev);
  EXPECT_GT(stddev[0], 10.0);  // not a blank page
  // Kept for people next to the test binary (wherever it is run from).
  const fs::path keep =
      fs::read_symlink("/proc/self/exe").parent_path() / "pipeline_report.png";
  fs::copy_file(shot, keep, fs::copy_options::overwrite_existing);
}

// For each step with options: one field changed through RunOptions'
// structs recomputes that step and exactly the steps that depend on it
// (their inputs change), and reuses every other step.
std::set<std::string> StepAndDependants(const std::string& step) {
  std::set<std::string> out = {step};
  for (const std::string& s : AllSteps()) {  // topological order
    for (const std::string& d : StepDependencies(s)) {
      if (out.count(d)) out.insert(s);
    }
  }
  return out;
}

TEST(PipelineOptionsTest, ChangedFieldRecomputesItsStepAndDependants) {
  TempDir tmp;
  const fs::path base = tmp / "base";
  testing::SimSessionOptions small;
  small.width = 120;
  small.exposures = {1.0 / 30, 1.0 / 250, 1.0 / 2000};
  small.sl_exposures = {1.0 / 60};
  small.projector_width = 128;
  small.projector_height = 96;
  ASSERT_TRUE(testing::RenderSimSession(base, small).ok());
  MemoryStore base_store;
  Recorder rec;
  ASSERT_TRUE(pipeline::Run(Discover(base), {}, base_store, rec).ok());

  struct Case {
    std::string step;
    std::function<void(StepOptions&)> edit;
  };
  const std::vector<Case> cases = {
      {"response", [](StepOptions& o) { o.experiment.response.lambda = 30; }},
      {"hdr",
       [](StepOptions& o) { o.experiment.merge.per_channel_weights = false; }},
      {"tonemap",
       [](StepOptions& o) { o.experiment.tonemap.saturation = 0.8; }},
      {"sl_groundtruth",
       [](StepOptions& o) { o.sl_ground_truth.use_illumination = false; }},
      {"stereo", [](StepOptions& o) { o.experiment.ldr_stereo.alpha = 0.6; }},
      {"stereo",
       [](StepOptions& o) { o.experiment.hdr_stereo.tau_color = 4.0 / 255; }},
      {"stereo", [](StepOptions& o) { o.experiment.matching_width = 80; }},
      {"fusion", [](StepOptions& o) { o.experiment.fusion.lambda = 3; }},
      {"fusion",
       [](StepOptions& o) {
         o.experiment.robust_fusion.window_fraction = 0.2;
       }},
      // The thesis' fusion, with the candidates' left-right checks
      // weighing in (disparity/<method>_lr.png).
      {"fusion",
       [](StepOptions& o) {
         o.experiment.robust_fusion.enabled = false;
         o.experiment.inconsistent_confidence = 0.5;
       }},
      {"evaluate",
       [](StepOptions& o) { o.experiment.evaluation.disparity_scale = 1.01; }},
  };
  int n = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.step);
    const fs::path dir = tmp / absl::StrCat("case", n++);
    fs::copy(base, dir, fs::copy_options::recursive);
    MemoryStore store = base_store;
    RunOptions o;
    c.edit(o.step_options);
    absl::StatusOr<RunSummary> s = pipeline::Run(Discover(dir), o, store, rec);
    ASSERT_TRUE(s.ok()) << s.status();
    const std::set<std::string> expected = StepAndDependants(c.step);
    EXPECT_EQ(AsSet(s->computed), expected);
    for (const std::string& step : s->reused) {
      EXPECT_EQ(expected.count(step), 0u) << step;
    }
    EXPECT_EQ(s->computed.size() + s->reused.size(), AllSteps().size());
    // Run again with the same options: nothing left to do.
    s = pipeline::Run(Discover(dir), o, store, rec);
    ASSERT_TRUE(s.ok()) << s.status();
    EXPECT_TRUE(s->computed.empty()) << ::testing::PrintToString(s->computed);
  }
  // Export has no option struct: its parameters are the session's. The
  // baseline is also shown by the report (its own parameter, not through
  // export's files).
  const fs::path dir = tmp / "export";
  fs::copy(base, dir, fs::copy_options::recursive);
  MemoryStore store = base_store;
  SessionInput in = Discover(dir);
  in.baseline_mm = 120;
  absl::StatusOr<RunSummary> s = pipeline::Run(in, {}, store, rec);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(AsSet(s->computed), (std::set<std::string>{"export", "report"}));
}

TEST(PipelineOptionsTest, BadOptionsNameTheFieldAndChangeNothing) {
  TempDir tmp;
  ASSERT_TRUE(testing::CopyCachedSimSession(tmp / "s").ok());
  MemoryStore store;
  Recorder rec;
  const std::vector<std::pair<std::function<void(StepOptions&)>, std::string>>
      cases = {
          {[](StepOptions& o) { o.experiment.response.samples = 1; },
           "experiment.response.samples is 1"},
          {[](StepOptions& o) { o.experiment.tonemap.guided.radius = 0; },
           "experiment.tonemap.guided.radius is 0"},
          {[](StepOptions& o) { o.experiment.ldr_stereo.radius = 0; },
           "experiment.ldr_stereo.radius is 0"},
          {[](StepOptions& o) { o.experiment.hdr_stereo.alpha = 2; },
           "experiment.hdr_stereo.alpha is 2"},
          {[](StepOptions& o) { o.experiment.fusion.sigma = 0; },
           "experiment.fusion.sigma is 0"},
          {[](StepOptions& o) { o.experiment.matching_width = 10; },
           "experiment.matching_width is 10; it must be 0 (full size) or in "
           "[64, 16384]"},
          {[](StepOptions& o) { o.sl_decode.min_lit = 2; },
           "sl_decode.min_lit is 2"},
          {[](StepOptions& o) { o.experiment.evaluation.thresholds = {1}; },
           "experiment.evaluation.thresholds must be {0.5, 1, 2, 4}"},
      };
  for (const auto& [edit, message] : cases) {
    RunOptions o;
    edit(o.step_options);
    EXPECT_THAT(pipeline::Run(Discover(tmp / "s"), o, store, rec),
                testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                  ::testing::HasSubstr(message)));
  }
  EXPECT_TRUE(store.steps.empty());
  EXPECT_FALSE(fs::exists(tmp / "s" / "decoded"));
}

// A session wider than matching_width is matched and fused at that width
// and every disparity comes back at the images' size, scored against the
// full-size truths: the simulator's and the structured light decoded at
// full size. 480 px matched at 240 px.
TEST(PipelineSessionTest, MatchesAtAWorkingSize) {
  TempDir tmp;
  testing::SimSessionOptions session;
  session.width = 480;
  ASSERT_OK(testing::RenderSimSession(tmp / "s", session));
  MemoryStore store;
  Recorder rec;
  RunOptions o;
  o.step_options.experiment.matching_width = 240;
  ASSERT_OK_AND_ASSIGN(const RunSummary s,
                       pipeline::Run(Discover(tmp / "s"), o, store, rec));
  EXPECT_THAT(rec.infos, ::testing::Contains(::testing::HasSubstr(
                             "at 240 x 180 (matching_width)")));
  // What the fusion's last steps changed is logged.
  EXPECT_THAT(rec.infos, ::testing::Contains(::testing::AllOf(
                             ::testing::HasSubstr("fusion: planes on "),
                             ::testing::HasSubstr("speckle filter"))));
  for (const std::string& m : Methods()) {
    SCOPED_TRACE(m);
    ASSERT_OK_AND_ASSIGN(
        const cv::Mat full,
        io::ReadPfm(tmp / "s" / absl::StrCat("disparity/", m, ".pfm")));
    EXPECT_EQ(full.size(), cv::Size(480, 360));
    ASSERT_OK_AND_ASSIGN(
        const cv::Mat matched,
        io::ReadPfm(tmp / "s" /
                    absl::StrCat("disparity/matching/", m, ".pfm")));
    EXPECT_EQ(matched.size(), cv::Size(240, 180));
  }
  ASSERT_OK_AND_ASSIGN(
      const cv::Mat gt,
      io::ReadPfm(tmp / "s" / "ground_truth/structured_light/disp0GT.pfm"));
  EXPECT_EQ(gt.size(), cv::Size(480, 360));

  std::cout << FormatMetrics(s.metrics);
  const Metric* fused = Find(s.metrics, "simulation", "fused");
  const Metric* ldr = Find(s.metrics, "simulation", "ldr");
  const Metric* sl = Find(s.metrics, "simulation", kGroundTruthMethod);
  ASSERT_NE(fused, nullptr);
  ASSERT_NE(ldr, nullptr);
  ASSERT_NE(sl, nullptr);
  // Disparities are 2x those matched: bad-2 px here is bad-1 px there.
  EXPECT_LT(fused->rmse, 2.0);   // measured 1.464
  EXPECT_LT(fused->bad_2, 8.0);  // measured 3.7 %
  EXPECT_LT(fused->rmse, 0.9 * ldr->rmse);
  // The ground truth is decoded at full size, not matched: sub-pixel.
  EXPECT_LT(sl->rmse, 0.4);  // measured 0.261

  ASSERT_OK_AND_ASSIGN(const std::string page,
                       io::ReadFileBytes(tmp / "s" / "report/index.html"));
  EXPECT_THAT(page, ::testing::HasSubstr("240 x 180 (matching_width"));
}

// The whole number that starts right after the first `prefix` after
// `from` in `text`; -1 when there is none.
int64_t NumberAfter(const std::string& text, const std::string& prefix,
                    size_t from = 0) {
  size_t at = text.find(prefix, from);
  if (at == std::string::npos) return -1;
  at += prefix.size();
  size_t end = at;
  while (end < text.size() && absl::ascii_isdigit(text[end])) ++end;
  int64_t value = -1;
  return absl::SimpleAtoi(text.substr(at, end - at), &value) ? value : -1;
}

// hdrstereo-proc says how much memory it expected the run to need and how
// much it took: the estimate must cover the run (pipeline/memory_estimate.h;
// at this size mostly the process itself).
void ProcMemoryStaysWithinItsEstimate() {
  TempDir tmp;
  ASSERT_OK(testing::CopyCachedSimSession(tmp / "s"));
  const testing::CommandResult r =
      testing::Proc({"pipeline", "--session-dir", (tmp / "s").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // "memory: estimated about 228 MiB at the peak (...)" and "memory: peak
  // resident 98 MiB (100112 kB)".
  const int64_t estimated_mib = NumberAfter(r.err, "memory: estimated about ");
  ASSERT_GT(estimated_mib, 0) << r.err;
  ASSERT_NE(r.err.find(absl::StrCat(estimated_mib, " MiB at the peak")),
            std::string::npos)
      << r.err;
  const int64_t peak_kb =
      NumberAfter(r.err, " (", r.err.find("memory: peak resident "));
  ASSERT_GT(peak_kb, 0) << r.err;
  const int64_t estimated_kb = estimated_mib * 1024;
  std::cout << "hdrstereo-proc pipeline: peak " << peak_kb << " kB, estimated "
            << estimated_kb << " kB\n";
  EXPECT_LE(peak_kb, estimated_kb);
}

// One process per TEST under ctest, and each renders the session: the
// checks are grouped so that the full run is done three times, not twelve.
TEST(PipelineSessionTest, FullRun) {
  FindsFramesTruthAndIntrinsics();
  FullRunWritesEveryFileWithItsRecordedHash();
  MetricsAgainstSimulatorAndStructuredLight();
  MiddleburyExportIsReadable();
  LoadsInHeadlessChromium();
  ProcMemoryStaysWithinItsEstimate();
}

TEST(PipelineSessionTest, ReuseAndRecompute) {
  SecondRunRecomputesNothing();
  DeletedArtifactRecomputesOnlyItsStep();
  ChangedArtifactRecomputesItsDependents();
  ForceRecomputesEverything();
  CancelStopsTheRun();
  RunsAndReusesThroughTheStateFile();
}

TEST(PipelineSessionTest, BadInput) {
  NoFramesIsFailedPrecondition();
  MissingBitPlaneIsFailedPreconditionAndKeepsOutputs();
  NoGroundTruthWarnsAndWritesNoMetrics();
}

}  // namespace
}  // namespace hdrstereo::pipeline
