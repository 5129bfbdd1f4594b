// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/pipeline/session_files.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"
#include "processing/io/middlebury.h"
#include "processing/io/sha256.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json ArtifactToJson(const Artifact& a) {
  return json{{"step", a.step},     {"kind", a.kind},
              {"path", a.path},     {"params", a.params_json},
              {"sha256", a.sha256}, {"size_bytes", a.size_bytes}};
}

Artifact ArtifactFromJson(const json& j) {
  Artifact a;
  a.step = j.value("step", "");
  a.kind = j.value("kind", "");
  a.path = j.value("path", "");
  a.params_json = j.value("params", "");
  a.sha256 = j.value("sha256", "");
  a.size_bytes = j.value("size_bytes", int64_t{0});
  return a;
}

json MetricToJson(const Metric& m) {
  return json{{"method", m.method},    {"ground_truth", m.ground_truth},
              {"rmse", m.rmse},        {"mae", m.mae},
              {"bad_0_5", m.bad_0_5},  {"bad_1", m.bad_1},
              {"bad_2", m.bad_2},      {"bad_4", m.bad_4},
              {"coverage", m.coverage}};
}

Metric MetricFromJson(const json& j) {
  Metric m;
  m.method = j.value("method", "");
  m.ground_truth = j.value("ground_truth", "");
  m.rmse = j.value("rmse", 0.0);
  m.mae = j.value("mae", 0.0);
  m.bad_0_5 = j.value("bad_0_5", 0.0);
  m.bad_1 = j.value("bad_1", 0.0);
  m.bad_2 = j.value("bad_2", 0.0);
  m.bad_4 = j.value("bad_4", 0.0);
  m.coverage = j.value("coverage", 0.0);
  return m;
}

}  // namespace

namespace {
absl::StatusOr<SessionInput> DiscoverSessionOrThrow(
    const fs::path& session_dir);
}  // namespace

absl::StatusOr<SessionInput> DiscoverSession(const fs::path& session_dir) {
  try {
    return DiscoverSessionOrThrow(session_dir);
  } catch (const fs::filesystem_error& e) {
    return absl::InternalError(
        absl::StrCat("discovering ", session_dir.string(), ": ", e.what()));
  }
}

absl::StatusOr<JsonRunStore> JsonRunStore::Open(fs::path path) {
  try {
    return OpenOrThrow(std::move(path));
  } catch (const json::exception& e) {
    return absl::DataLossError(absl::StrCat("pipeline state file: ", e.what()));
  }
}

namespace {
absl::StatusOr<SessionInput> DiscoverSessionOrThrow(
    const fs::path& session_dir) {
  std::error_code ec;
  if (!fs::is_directory(session_dir, ec)) {
    return absl::NotFoundError(
        absl::StrCat(session_dir.string(), ": not a session folder"));
  }
  SessionInput in;
  in.session_dir = fs::absolute(session_dir);
  in.session_name = in.session_dir.filename().string();
  const fs::path captures = in.session_dir / io::kCapturesDir;
  std::vector<std::tuple<int64_t, int, std::string, std::string, FrameInput>>
      found;
  int64_t latest_stereo = -1;
  if (fs::is_directory(captures, ec)) {
    for (const fs::directory_entry& file :
         fs::recursive_directory_iterator(captures)) {
      const std::string name = file.path().filename().string();
      if (!file.is_regular_file() ||
          absl::StrContains(name, io::kTempFileMarker)) {
        continue;
      }
      const std::string rel =
          fs::relative(file.path(), in.session_dir).generic_string();
      // Truth files and anything else outside the frame layout.
      absl::StatusOr<io::FramePath> p = io::ParseFramePath(rel);
      if (!p.ok() || p->view_index > 1) continue;
      FrameInput f;
      f.path = rel;
      f.capture_kind = io::KindOfRole(p->key.role);
      f.capture_id = p->capture_id;
      f.role = p->key.role;
      f.view_index = p->view_index;
      f.exposure_s = p->key.exposure_s;
      f.pattern = p->key.pattern;
      f.inverse = p->key.inverse;
      if (p->key.role == io::FrameRole::kStereo) {
        latest_stereo = std::max(latest_stereo, p->capture_id);
      }
      found.emplace_back(f.capture_id, f.view_index, io::FrameRoleName(f.role),
                         name, std::move(f));
    }
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) {
    return std::tie(std::get<0>(a), std::get<1>(a), std::get<2>(a),
                    std::get<3>(a)) < std::tie(std::get<0>(b), std::get<1>(b),
                                               std::get<2>(b), std::get<3>(b));
  });
  for (auto& t : found) in.frames.push_back(std::move(std::get<4>(t)));
  if (latest_stereo >= 0) {
    const fs::path truth = in.session_dir / io::TruthDir(latest_stereo);
    if (fs::exists(truth / "disp0.pfm", ec)) {
      in.sim_truth_disparity =
          fs::relative(truth / "disp0.pfm", in.session_dir).generic_string();
      if (fs::exists(truth / "nonocc0.png", ec)) {
        in.sim_truth_nonoccluded =
            fs::relative(truth / "nonocc0.png", in.session_dir)
                .generic_string();
      }
      // Without a readable calib.txt the export falls back to a nominal
      // camera, and says so.
      ApplyCalib(truth / io::kCalibFile, &in).IgnoreError();
    }
  }
  return in;
}

}  // namespace

absl::StatusOr<JsonRunStore> JsonRunStore::OpenOrThrow(fs::path path) {
  JsonRunStore store(std::move(path));
  std::error_code ec;
  if (!fs::exists(store.path_, ec)) return store;
  ASSIGN_OR_RETURN(std::string text, io::ReadFileBytes(store.path_));
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) {
    return absl::DataLossError(
        absl::StrCat(store.path_.string(), ": not a pipeline state file"));
  }
  if (j.contains("steps") && j["steps"].is_object()) {
    for (const auto& [step, entry] : j["steps"].items()) {
      std::vector<Artifact> artifacts;
      if (entry.contains("artifacts") && entry["artifacts"].is_array()) {
        for (const json& a : entry["artifacts"]) {
          artifacts.push_back(ArtifactFromJson(a));
        }
      }
      store.steps_[step] = {entry.value("input_hash", ""),
                            std::move(artifacts)};
    }
  }
  if (j.contains("metrics") && j["metrics"].is_array()) {
    for (const json& m : j["metrics"]) {
      store.metrics_.push_back(MetricFromJson(m));
    }
  }
  return store;
}

std::vector<Artifact> JsonRunStore::Lookup(const std::string& step,
                                           const std::string& input_hash) {
  auto it = steps_.find(step);
  if (it == steps_.end() || it->second.first != input_hash) return {};
  return it->second.second;
}

absl::Status JsonRunStore::Record(const std::string& step,
                                  const std::string& input_hash,
                                  const std::vector<Artifact>& artifacts) {
  steps_[step] = {input_hash, artifacts};
  return Save();
}

absl::Status JsonRunStore::RecordMetrics(const std::vector<Metric>& metrics) {
  metrics_ = metrics;
  return Save();
}

std::optional<std::pair<std::string, std::vector<Artifact>>>
JsonRunStore::Entry(const std::string& step) const {
  auto it = steps_.find(step);
  if (it == steps_.end()) return std::nullopt;
  return it->second;
}

absl::Status JsonRunStore::Save() const {
  json steps = json::object();
  for (const auto& [step, entry] : steps_) {
    json artifacts = json::array();
    for (const Artifact& a : entry.second) {
      artifacts.push_back(ArtifactToJson(a));
    }
    steps[step] = json{{"input_hash", entry.first}, {"artifacts", artifacts}};
  }
  json metrics = json::array();
  for (const Metric& m : metrics_) metrics.push_back(MetricToJson(m));
  const json j{{"steps", steps}, {"metrics", metrics}};
  return io::WriteFileAtomically(path_, j.dump(2) + "\n");
}

std::string MetricsToJson(const std::vector<Metric>& metrics) {
  json rows = json::array();
  for (const Metric& m : metrics) rows.push_back(MetricToJson(m));
  return json{{"metrics", rows}}.dump(2) + "\n";
}

absl::StatusOr<std::vector<Metric>> MetricsFromJson(const std::string& text) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object() || !j.contains("metrics") ||
      !j["metrics"].is_array()) {
    return absl::DataLossError("metrics.json: not a metrics file");
  }
  std::vector<Metric> out;
  try {
    for (const json& m : j["metrics"]) out.push_back(MetricFromJson(m));
  } catch (const json::exception& e) {
    return absl::DataLossError(absl::StrCat("metrics.json: ", e.what()));
  }
  return out;
}

std::vector<Metric> SortMetrics(std::vector<Metric> metrics) {
  std::stable_sort(metrics.begin(), metrics.end(),
                   [](const Metric& a, const Metric& b) {
                     return std::tie(a.ground_truth, a.rmse) <
                            std::tie(b.ground_truth, b.rmse);
                   });
  return metrics;
}

std::string FormatMetrics(const std::vector<Metric>& metrics) {
  const std::vector<Metric> sorted = SortMetrics(metrics);
  std::string out =
      "| ground truth | method | RMSE | MAE | bad-0.5 % | bad-1 % | bad-2 % | "
      "bad-4 % | coverage % |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
  char buf[256];
  for (const Metric& m : sorted) {
    std::snprintf(buf, sizeof(buf),
                  "| %s | %s | %.3f | %.3f | %.1f | %.1f | %.1f | %.1f | "
                  "%.1f |\n",
                  m.ground_truth.c_str(), m.method.c_str(), m.rmse, m.mae,
                  m.bad_0_5, m.bad_1, m.bad_2, m.bad_4, m.coverage);
    out += buf;
  }
  return out;
}

absl::Status ApplyCalib(const fs::path& path, SessionInput* in) {
  ASSIGN_OR_RETURN(const io::Calib calib, io::ReadCalib(path));
  if (in->baseline_mm <= 0) in->baseline_mm = calib.baseline_mm;
  if (!in->intrinsics) {
    in->intrinsics =
        SessionInput::Intrinsics{calib.fx, calib.fy, calib.cx, calib.cy};
  }
  return absl::OkStatus();
}

namespace {

json FrameToJson(const FrameInput& f) {
  return json{{"path", f.path},
              {"capture_kind", io::CaptureKindName(f.capture_kind)},
              {"capture_id", f.capture_id},
              {"role", io::FrameRoleName(f.role)},
              {"view_index", f.view_index},
              {"exposure_s", f.exposure_s},
              {"pattern", f.pattern},
              {"inverse", f.inverse},
              {"sha256", f.sha256}};
}

absl::StatusOr<FrameInput> FrameFromJson(const json& j) {
  FrameInput f;
  f.path = j.at("path").get<std::string>();
  ASSIGN_OR_RETURN(
      f.capture_kind,
      io::ParseCaptureKind(j.at("capture_kind").get<std::string>()));
  f.capture_id = j.at("capture_id").get<int64_t>();
  ASSIGN_OR_RETURN(f.role, io::ParseFrameRole(j.at("role").get<std::string>()));
  f.view_index = j.at("view_index").get<int>();
  f.exposure_s = j.at("exposure_s").get<double>();
  f.pattern = j.value("pattern", "");
  f.inverse = j.value("inverse", false);
  f.sha256 = j.value("sha256", "");
  return f;
}

// The whole status-code range, to read a code back by its name.
absl::StatusCode ParseStatusCode(const std::string& name) {
  for (int code = 0;
       code <= static_cast<int>(absl::StatusCode::kUnauthenticated); ++code) {
    if (absl::StatusCodeToString(static_cast<absl::StatusCode>(code)) == name) {
      return static_cast<absl::StatusCode>(code);
    }
  }
  return absl::StatusCode::kUnknown;
}

absl::StatusOr<json> ReadJson(const fs::path& path, absl::string_view what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": no ", what));
  }
  ASSIGN_OR_RETURN(std::string text, io::ReadFileBytes(path));
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) {
    return absl::DataLossError(absl::StrCat(path.string(), ": not a ", what));
  }
  return j;
}

absl::StatusOr<JobRequest> RequestFromJson(const json& j,
                                           const fs::path& session_dir) {
  JobRequest request;
  SessionInput& in = request.input;
  in.session_dir = session_dir;
  in.session_name = j.at("session").get<std::string>();
  for (const json& f : j.at("frames")) {
    ASSIGN_OR_RETURN(FrameInput frame, FrameFromJson(f));
    in.frames.push_back(std::move(frame));
  }
  in.baseline_mm = j.at("baseline_mm").get<double>();
  if (j.contains("projector_size")) {
    in.projector_size = std::make_pair(j["projector_size"].at(0).get<int>(),
                                       j["projector_size"].at(1).get<int>());
  }
  for (const json& row : j.at("capture_summary")) {
    in.capture_summary.emplace_back(row.at(0).get<std::string>(),
                                    row.at(1).get<std::string>());
  }
  in.sim_truth_disparity = j.value("sim_truth_disparity", "");
  in.sim_truth_nonoccluded = j.value("sim_truth_nonoccluded", "");
  if (j.contains("intrinsics")) {
    const json& k = j["intrinsics"];
    in.intrinsics = SessionInput::Intrinsics{.fx = k.at("fx").get<double>(),
                                             .fy = k.at("fy").get<double>(),
                                             .cx = k.at("cx").get<double>(),
                                             .cy = k.at("cy").get<double>()};
  }
  request.steps = j.at("steps").get<std::vector<std::string>>();
  request.force = j.at("force").get<bool>();
  return request;
}

}  // namespace

absl::Status WriteJobRequest(const fs::path& job_dir,
                             const JobRequest& request) {
  const SessionInput& in = request.input;
  json frames = json::array();
  for (const FrameInput& f : in.frames) frames.push_back(FrameToJson(f));
  json summary = json::array();
  for (const auto& [key, value] : in.capture_summary) {
    summary.push_back(json::array({key, value}));
  }
  json j{{"session", in.session_name},
         {"frames", frames},
         {"baseline_mm", in.baseline_mm},
         {"capture_summary", summary},
         {"sim_truth_disparity", in.sim_truth_disparity},
         {"sim_truth_nonoccluded", in.sim_truth_nonoccluded},
         {"steps", request.steps},
         {"force", request.force}};
  if (in.projector_size) {
    j["projector_size"] =
        json::array({in.projector_size->first, in.projector_size->second});
  }
  if (in.intrinsics) {
    j["intrinsics"] = json{{"fx", in.intrinsics->fx},
                           {"fy", in.intrinsics->fy},
                           {"cx", in.intrinsics->cx},
                           {"cy", in.intrinsics->cy}};
  }
  return io::WriteFileAtomically(job_dir / kJobRequestFile, j.dump(2) + "\n");
}

absl::StatusOr<JobRequest> ReadJobRequest(const fs::path& job_dir,
                                          const fs::path& session_dir) {
  const fs::path path = job_dir / kJobRequestFile;
  ASSIGN_OR_RETURN(const json j, ReadJson(path, "pipeline job request"));
  try {
    return RequestFromJson(j, session_dir);
  } catch (const json::exception& e) {
    return absl::DataLossError(absl::StrCat(
        path.string(), ": not a pipeline job request: ", e.what()));
  }
}

absl::Status WriteJobResult(const fs::path& job_dir, const JobResult& result) {
  json steps = json::array();
  for (const StepRecord& r : result.steps) {
    json artifacts = json::array();
    for (const Artifact& a : r.artifacts)
      artifacts.push_back(ArtifactToJson(a));
    json step{{"step", r.step},
              {"input_hash", r.input_hash},
              {"computed", r.computed},
              {"artifacts", artifacts}};
    if (r.seconds.has_value()) step["seconds"] = *r.seconds;
    steps.push_back(std::move(step));
  }
  const json j{{"code", absl::StatusCodeToString(result.status.code())},
               {"message", std::string(result.status.message())},
               {"steps", steps}};
  return io::WriteFileAtomically(job_dir / kJobResultFile, j.dump(2) + "\n");
}

absl::StatusOr<JobResult> ReadJobResult(const fs::path& job_dir) {
  const fs::path path = job_dir / kJobResultFile;
  ASSIGN_OR_RETURN(const json j, ReadJson(path, "pipeline job result"));
  try {
    JobResult result;
    const absl::StatusCode code =
        ParseStatusCode(j.at("code").get<std::string>());
    result.status = absl::Status(code, j.at("message").get<std::string>());
    for (const json& s : j.at("steps")) {
      StepRecord r;
      r.step = s.at("step").get<std::string>();
      r.input_hash = s.at("input_hash").get<std::string>();
      r.computed = s.at("computed").get<bool>();
      for (const json& a : s.at("artifacts")) {
        r.artifacts.push_back(ArtifactFromJson(a));
      }
      if (s.contains("seconds")) r.seconds = s.at("seconds").get<double>();
      result.steps.push_back(std::move(r));
    }
    return result;
  } catch (const json::exception& e) {
    return absl::DataLossError(
        absl::StrCat(path.string(), ": not a pipeline job result: ", e.what()));
  }
}

absl::Status VerifyFrames(const SessionInput& input) {
  for (const FrameInput& f : input.frames) {
    const fs::path path = input.session_dir / f.path;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      return absl::FailedPreconditionError(absl::StrCat(
          "frame ", f.path, " is missing from ", input.session_dir.string()));
    }
    if (f.sha256.empty()) continue;
    ASSIGN_OR_RETURN(const std::string sha, io::Sha256HexOfFile(path));
    if (sha != f.sha256) {
      return absl::DataLossError(absl::StrCat("frame ", f.path, " has sha256 ",
                                              sha, ", not the ", f.sha256,
                                              " recorded at capture"));
    }
  }
  return absl::OkStatus();
}

absl::Status VerifyArtifacts(const fs::path& session_dir,
                             const std::vector<Artifact>& artifacts) {
  for (const Artifact& a : artifacts) {
    absl::StatusOr<std::string> sha = io::Sha256HexOfFile(session_dir / a.path);
    if (!sha.ok()) {
      return absl::DataLossError(absl::StrCat("artifact ", a.path, " of step ",
                                              a.step, ": ",
                                              sha.status().message()));
    }
    if (*sha != a.sha256) {
      return absl::DataLossError(
          absl::StrCat("artifact ", a.path, " of step ", a.step, " has sha256 ",
                       *sha, ", not the ", a.sha256, " the run recorded"));
    }
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::pipeline
