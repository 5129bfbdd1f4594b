// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/pipeline/session_files.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"
#include "processing/io/json_input.h"
#include "processing/io/middlebury.h"
#include "processing/io/relative_path.h"
#include "processing/io/sha256.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Limits on the files a run elsewhere (a cluster node) writes into the
// session folder for the daemon, and that the node reads back: request.json,
// result.json, pipeline_state.json, metrics.json.
// - The largest file: a request of kMaxFrames frames is about 30 MB.
constexpr size_t kMaxFileBytes = size_t{64} << 20;
// - A session's frames: e.g. 20 captures of 50 structured-light patterns in
//   5 exposures from 2 views.
constexpr size_t kMaxFrames = 100000;
// - Steps of a run (the pipeline has about 15) and the files of one step.
constexpr size_t kMaxSteps = 256;
constexpr size_t kMaxArtifacts = 100000;
constexpr size_t kMaxMetrics = 100000;
constexpr size_t kMaxSummaryRows = 1000;
// - A name, hash or kind: kMaxNameBytes; and a longer text (a step's
//   parameters as JSON, a status message, a summary value).
constexpr size_t kMaxTextBytes = 64 << 10;
// - Views of a rig (daemon/jobs/capture_plan.h: at most 16).
constexpr int64_t kMaxViewIndex = 15;
// - Exposures, baselines, intrinsics, durations and metrics: finite and
//   far from overflowing what is computed from them.
constexpr double kMaxNumber = 1e12;

// Reading a JSON document received from elsewhere: every error is
// INVALID_ARGUMENT "<field>: <why>" naming the field (e.g.
// "steps[2].artifacts[0].path"); the readers turn it into DATA_LOSS "not a
// <document>: ...".
absl::Status Bad(absl::string_view field, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", why));
}

std::string Field(absl::string_view parent, absl::string_view key) {
  return parent.empty() ? std::string(key) : absl::StrCat(parent, ".", key);
}

std::string Index(absl::string_view array, size_t i) {
  return absl::StrCat(array, "[", i, "]");
}

// object[key]: nullptr when it is absent and not `required`.
absl::StatusOr<const json*> Member(const json& object, absl::string_view where,
                                   const char* key, bool required) {
  if (!object.is_object()) return Bad(where, "expected an object");
  const auto it = object.find(key);
  if (it == object.end()) {
    if (required) return Bad(Field(where, key), "missing");
    return nullptr;
  }
  return &*it;
}

absl::Status CheckString(const json& j, absl::string_view field,
                         size_t max_bytes) {
  if (!j.is_string()) return Bad(field, "expected a string");
  const std::string& v = j.get_ref<const std::string&>();
  if (v.size() > max_bytes) {
    return Bad(field,
               absl::StrCat(QuoteInput(v), " is longer than the limit of ",
                            max_bytes, " bytes"));
  }
  return absl::OkStatus();
}

// Each reader leaves `out` alone when the key is absent and not required.
absl::Status ReadString(const json& object, absl::string_view where,
                        const char* key, size_t max_bytes, std::string* out,
                        bool required = true) {
  ASSIGN_OR_RETURN(const json* j, Member(object, where, key, required));
  if (j == nullptr) return absl::OkStatus();
  RETURN_IF_ERROR(CheckString(*j, Field(where, key), max_bytes));
  *out = j->get<std::string>();
  return absl::OkStatus();
}

// A path relative to the session folder (io::ValidateRelativePath); an
// `optional` one may be absent or "" (none).
absl::Status ReadPath(const json& object, absl::string_view where,
                      const char* key, std::string* out,
                      bool optional = false) {
  RETURN_IF_ERROR(ReadString(object, where, key, io::kMaxRelativePathBytes, out,
                             !optional));
  if (optional && out->empty()) return absl::OkStatus();
  if (absl::Status s = io::ValidateRelativePath(*out); !s.ok()) {
    return Bad(Field(where, key), s.message());
  }
  return absl::OkStatus();
}

absl::Status ReadInt(const json& object, absl::string_view where,
                     const char* key, int64_t min, int64_t max, int64_t* out,
                     bool required = true) {
  ASSIGN_OR_RETURN(const json* j, Member(object, where, key, required));
  if (j == nullptr) return absl::OkStatus();
  ASSIGN_OR_RETURN(*out, io::JsonIntInRange(*j, Field(where, key), min, max));
  return absl::OkStatus();
}

absl::Status ReadNumber(const json& object, absl::string_view where,
                        const char* key, double min, double max, double* out,
                        bool required = true) {
  ASSIGN_OR_RETURN(const json* j, Member(object, where, key, required));
  if (j == nullptr) return absl::OkStatus();
  if (!j->is_number()) return Bad(Field(where, key), "expected a number");
  const double v = j->get<double>();
  if (!(v >= min && v <= max)) {
    return Bad(Field(where, key),
               absl::StrCat(v, " is outside [", min, ", ", max, "]"));
  }
  *out = v;
  return absl::OkStatus();
}

absl::Status ReadBool(const json& object, absl::string_view where,
                      const char* key, bool* out, bool required = true) {
  ASSIGN_OR_RETURN(const json* j, Member(object, where, key, required));
  if (j == nullptr) return absl::OkStatus();
  if (!j->is_boolean()) return Bad(Field(where, key), "expected true or false");
  *out = j->get<bool>();
  return absl::OkStatus();
}

// object[key] as an array of at most `max` elements; nullptr when it is
// absent and not `required`.
absl::StatusOr<const json*> ReadArray(const json& object,
                                      absl::string_view where, const char* key,
                                      size_t max, bool required = true) {
  ASSIGN_OR_RETURN(const json* j, Member(object, where, key, required));
  if (j == nullptr) return nullptr;
  if (!j->is_array()) return Bad(Field(where, key), "expected an array");
  if (j->size() > max) {
    return Bad(
        Field(where, key),
        absl::StrCat(j->size(), " elements, more than the limit of ", max));
  }
  return j;
}

// `text` as a JSON object; DATA_LOSS "not a <what>: ..." otherwise.
absl::StatusOr<json> ParseObject(absl::string_view text,
                                 absl::string_view what) {
  if (text.size() > kMaxFileBytes) {
    return absl::DataLossError(absl::StrCat("not a ", what, ": ", text.size(),
                                            " bytes, more than the limit of ",
                                            kMaxFileBytes));
  }
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    return absl::DataLossError(
        absl::StrCat("not a ", what, ": ", io::BoundedJsonError(e.what())));
  }
  if (!j.is_object()) {
    return absl::DataLossError(absl::StrCat("not a ", what, ": not an object"));
  }
  return j;
}

// A field's error as DATA_LOSS "not a <what>: <field>: <why>".
absl::Status NotA(absl::string_view what, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::DataLossError(
      absl::StrCat("not a ", what, ": ", status.message()));
}

// The bytes of a file of this kind, refused beyond kMaxFileBytes before
// they are read (DATA_LOSS "<path>: <what> of N bytes, more than the limit
// of ...; not read"); its absence is NOT_FOUND "<path>: no <what>".
absl::StatusOr<std::string> ReadDocument(const fs::path& path,
                                         absl::string_view what) {
  absl::StatusOr<std::string> text =
      io::ReadFileBytes(path, kMaxFileBytes, what);
  if (absl::IsNotFound(text.status())) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": no ", what));
  }
  if (absl::IsInvalidArgument(text.status())) {
    return absl::DataLossError(text.status().message());
  }
  return text;
}

json ArtifactToJson(const Artifact& a) {
  return json{{"step", a.step},     {"kind", a.kind},
              {"path", a.path},     {"params", a.params_json},
              {"sha256", a.sha256}, {"size_bytes", a.size_bytes}};
}

// Every field but the path may be absent (results written before it was
// kept).
absl::StatusOr<Artifact> ArtifactFromJson(const json& j,
                                          absl::string_view where) {
  Artifact a;
  RETURN_IF_ERROR(ReadString(j, where, "step", kMaxNameBytes, &a.step, false));
  RETURN_IF_ERROR(ReadString(j, where, "kind", kMaxNameBytes, &a.kind, false));
  RETURN_IF_ERROR(ReadPath(j, where, "path", &a.path));
  RETURN_IF_ERROR(
      ReadString(j, where, "params", kMaxTextBytes, &a.params_json, false));
  RETURN_IF_ERROR(
      ReadString(j, where, "sha256", kMaxNameBytes, &a.sha256, false));
  RETURN_IF_ERROR(
      ReadInt(j, where, "size_bytes", 0, INT64_MAX, &a.size_bytes, false));
  return a;
}

absl::StatusOr<std::vector<Artifact>> ArtifactsFromJson(const json& object,
                                                        absl::string_view where,
                                                        bool required) {
  ASSIGN_OR_RETURN(const json* list, ReadArray(object, where, "artifacts",
                                               kMaxArtifacts, required));
  std::vector<Artifact> out;
  if (list == nullptr) return out;
  for (size_t i = 0; i < list->size(); ++i) {
    ASSIGN_OR_RETURN(
        Artifact a,
        ArtifactFromJson((*list)[i], Index(Field(where, "artifacts"), i)));
    out.push_back(std::move(a));
  }
  return out;
}

json MetricToJson(const Metric& m) {
  return json{{"method", m.method},    {"ground_truth", m.ground_truth},
              {"rmse", m.rmse},        {"mae", m.mae},
              {"bad_0_5", m.bad_0_5},  {"bad_1", m.bad_1},
              {"bad_2", m.bad_2},      {"bad_4", m.bad_4},
              {"coverage", m.coverage}};
}

absl::StatusOr<Metric> MetricFromJson(const json& j, absl::string_view where) {
  Metric m;
  RETURN_IF_ERROR(
      ReadString(j, where, "method", kMaxNameBytes, &m.method, false));
  RETURN_IF_ERROR(ReadString(j, where, "ground_truth", kMaxNameBytes,
                             &m.ground_truth, false));
  for (const auto& [key, value] :
       {std::pair<const char*, double*>{"rmse", &m.rmse},
        {"mae", &m.mae},
        {"bad_0_5", &m.bad_0_5},
        {"bad_1", &m.bad_1},
        {"bad_2", &m.bad_2},
        {"bad_4", &m.bad_4},
        {"coverage", &m.coverage}}) {
    // JSON has no NaN or infinity: MetricsToJson writes a metric that could
    // not be computed (NaN), or an infinite one, as null, read back as NaN.
    ASSIGN_OR_RETURN(const json* number, Member(j, where, key, false));
    if (number != nullptr && number->is_null()) {
      *value = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    RETURN_IF_ERROR(
        ReadNumber(j, where, key, -kMaxNumber, kMaxNumber, value, false));
  }
  return m;
}

absl::StatusOr<std::vector<Metric>> MetricsFromArray(const json& object,
                                                     bool required) {
  ASSIGN_OR_RETURN(const json* rows,
                   ReadArray(object, "", "metrics", kMaxMetrics, required));
  std::vector<Metric> out;
  if (rows == nullptr) return out;
  for (size_t i = 0; i < rows->size(); ++i) {
    ASSIGN_OR_RETURN(Metric m, MetricFromJson((*rows)[i], Index("metrics", i)));
    out.push_back(std::move(m));
  }
  return out;
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
  std::error_code ec;
  if (!fs::exists(path, ec)) return JsonRunStore(std::move(path));
  ASSIGN_OR_RETURN(const std::string text,
                   ReadDocument(path, "pipeline state file"));
  return io::WithSource(path.string(), Parse(text, path));
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

absl::StatusOr<JsonRunStore> JsonRunStore::Parse(absl::string_view json_text,
                                                 fs::path path) {
  constexpr absl::string_view kWhat = "pipeline state file";
  ASSIGN_OR_RETURN(const json j, ParseObject(json_text, kWhat));
  JsonRunStore store(std::move(path));
  auto parse = [&]() -> absl::Status {
    ASSIGN_OR_RETURN(const json* steps, Member(j, "", "steps", false));
    if (steps != nullptr) {
      if (!steps->is_object()) return Bad("steps", "expected an object");
      if (steps->size() > kMaxSteps) {
        return Bad("steps",
                   absl::StrCat(steps->size(),
                                " steps, more than the limit of ", kMaxSteps));
      }
      for (const auto& [step, entry] : steps->items()) {
        if (step.size() > kMaxNameBytes) {
          return Bad("steps", absl::StrCat("the step name ", QuoteInput(step),
                                           " is longer than the limit of ",
                                           kMaxNameBytes, " bytes"));
        }
        const std::string where = absl::StrCat("steps[", QuoteInput(step), "]");
        std::string input_hash;
        RETURN_IF_ERROR(ReadString(entry, where, "input_hash", kMaxNameBytes,
                                   &input_hash, false));
        ASSIGN_OR_RETURN(std::vector<Artifact> artifacts,
                         ArtifactsFromJson(entry, where, false));
        store.steps_[step] = {std::move(input_hash), std::move(artifacts)};
      }
    }
    ASSIGN_OR_RETURN(store.metrics_, MetricsFromArray(j, false));
    return absl::OkStatus();
  };
  RETURN_IF_ERROR(NotA(kWhat, parse()));
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

std::vector<std::string> JsonRunStore::StepNames() const {
  std::vector<std::string> names;
  for (const auto& [step, entry] : steps_) names.push_back(step);
  return names;
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

namespace {

constexpr char kMetricsWhat[] = "metrics file";

// A metrics file's text; DATA_LOSS "not a metrics file: ...".
absl::StatusOr<std::vector<Metric>> ParseMetrics(absl::string_view text) {
  ASSIGN_OR_RETURN(const json j, ParseObject(text, kMetricsWhat));
  absl::StatusOr<std::vector<Metric>> metrics = MetricsFromArray(j, true);
  if (!metrics.ok()) return NotA(kMetricsWhat, metrics.status());
  return metrics;
}

}  // namespace

absl::StatusOr<std::vector<Metric>> MetricsFromJson(absl::string_view text) {
  return io::WithSource("metrics.json", ParseMetrics(text));
}

absl::StatusOr<std::vector<Metric>> ReadMetricsFile(const fs::path& path) {
  ASSIGN_OR_RETURN(const std::string text, ReadDocument(path, kMetricsWhat));
  return io::WithSource(path.string(), ParseMetrics(text));
}

std::vector<Metric> SortMetrics(std::vector<Metric> metrics) {
  std::stable_sort(metrics.begin(), metrics.end(),
                   [](const Metric& a, const Metric& b) {
                     // A NaN RMSE (not computed) goes last: compared as a
                     // number it would break the strict weak order that
                     // std::stable_sort needs.
                     const bool a_nan = std::isnan(a.rmse);
                     const bool b_nan = std::isnan(b.rmse);
                     return std::tie(a.ground_truth, a_nan, a.rmse) <
                            std::tie(b.ground_truth, b_nan, b.rmse);
                   });
  return metrics;
}

std::vector<bool> WorseThanLdr(const std::vector<Metric>& metrics) {
  std::map<std::string, double> ldr;  // by ground truth
  for (const Metric& m : metrics) {
    if (m.method == "ldr") ldr[m.ground_truth] = m.rmse;
  }
  std::vector<bool> worse;
  for (const Metric& m : metrics) {
    const auto it = ldr.find(m.ground_truth);
    // NaN compares false.
    worse.push_back(m.method != "ldr" && m.method != kGroundTruthMethod &&
                    it != ldr.end() && m.rmse > it->second);
  }
  return worse;
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

absl::StatusOr<FrameInput> FrameFromJson(const json& j,
                                         absl::string_view where) {
  FrameInput f;
  RETURN_IF_ERROR(ReadPath(j, where, "path", &f.path));
  std::string name;
  RETURN_IF_ERROR(ReadString(j, where, "capture_kind", kMaxNameBytes, &name));
  absl::StatusOr<io::CaptureKind> kind = io::ParseCaptureKind(name);
  if (!kind.ok())
    return Bad(Field(where, "capture_kind"), kind.status().message());
  f.capture_kind = *kind;
  RETURN_IF_ERROR(ReadInt(j, where, "capture_id", 0, INT64_MAX, &f.capture_id));
  RETURN_IF_ERROR(ReadString(j, where, "role", kMaxNameBytes, &name));
  absl::StatusOr<io::FrameRole> role = io::ParseFrameRole(name);
  if (!role.ok()) return Bad(Field(where, "role"), role.status().message());
  f.role = *role;
  int64_t view_index = 0;
  RETURN_IF_ERROR(
      ReadInt(j, where, "view_index", 0, kMaxViewIndex, &view_index));
  f.view_index = static_cast<int>(view_index);
  RETURN_IF_ERROR(
      ReadNumber(j, where, "exposure_s", 0, kMaxNumber, &f.exposure_s));
  RETURN_IF_ERROR(
      ReadString(j, where, "pattern", kMaxNameBytes, &f.pattern, false));
  RETURN_IF_ERROR(ReadBool(j, where, "inverse", &f.inverse, false));
  RETURN_IF_ERROR(
      ReadString(j, where, "sha256", kMaxNameBytes, &f.sha256, false));
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

absl::StatusOr<JobRequest> RequestFromJson(const json& j,
                                           const fs::path& session_dir) {
  JobRequest request;
  SessionInput& in = request.input;
  in.session_dir = session_dir;
  RETURN_IF_ERROR(
      ReadString(j, "", "session", kMaxNameBytes, &in.session_name));
  ASSIGN_OR_RETURN(const json* frames, ReadArray(j, "", "frames", kMaxFrames));
  for (size_t i = 0; i < frames->size(); ++i) {
    ASSIGN_OR_RETURN(FrameInput frame,
                     FrameFromJson((*frames)[i], Index("frames", i)));
    in.frames.push_back(std::move(frame));
  }
  RETURN_IF_ERROR(
      ReadNumber(j, "", "baseline_mm", 0, kMaxNumber, &in.baseline_mm));
  ASSIGN_OR_RETURN(const json* size,
                   ReadArray(j, "", "projector_size", 2, false));
  if (size != nullptr) {
    // [width, height], each at most what a display can have.
    if (size->size() != 2) {
      return Bad("projector_size", "expected [width, height]");
    }
    int64_t side[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      ASSIGN_OR_RETURN(
          side[k], io::JsonIntInRange((*size)[k], Index("projector_size", k), 1,
                                      kMaxProjectorSide));
    }
    in.projector_size =
        std::make_pair(static_cast<int>(side[0]), static_cast<int>(side[1]));
  }
  ASSIGN_OR_RETURN(const json* summary,
                   ReadArray(j, "", "capture_summary", kMaxSummaryRows));
  for (size_t i = 0; i < summary->size(); ++i) {
    const std::string where = Index("capture_summary", i);
    const json& row = (*summary)[i];
    if (!row.is_array() || row.size() != 2) {
      return Bad(where, "expected [key, value]");
    }
    for (int k = 0; k < 2; ++k) {
      RETURN_IF_ERROR(CheckString(row[k], Index(where, k), kMaxTextBytes));
    }
    in.capture_summary.emplace_back(row[0].get<std::string>(),
                                    row[1].get<std::string>());
  }
  RETURN_IF_ERROR(ReadPath(j, "", "sim_truth_disparity",
                           &in.sim_truth_disparity, /*optional=*/true));
  RETURN_IF_ERROR(ReadPath(j, "", "sim_truth_nonoccluded",
                           &in.sim_truth_nonoccluded, /*optional=*/true));
  ASSIGN_OR_RETURN(const json* k, Member(j, "", "intrinsics", false));
  if (k != nullptr) {
    SessionInput::Intrinsics intrinsics;
    for (const auto& [key, value] :
         {std::pair<const char*, double*>{"fx", &intrinsics.fx},
          {"fy", &intrinsics.fy},
          {"cx", &intrinsics.cx},
          {"cy", &intrinsics.cy}}) {
      RETURN_IF_ERROR(
          ReadNumber(*k, "intrinsics", key, -kMaxNumber, kMaxNumber, value));
    }
    in.intrinsics = intrinsics;
  }
  ASSIGN_OR_RETURN(const json* steps, ReadArray(j, "", "steps", kMaxSteps));
  for (size_t i = 0; i < steps->size(); ++i) {
    RETURN_IF_ERROR(CheckString((*steps)[i], Index("steps", i), kMaxNameBytes));
    request.steps.push_back((*steps)[i].get<std::string>());
  }
  RETURN_IF_ERROR(ReadBool(j, "", "force", &request.force));
  return request;
}

absl::StatusOr<StepRecord> StepFromJson(const json& s,
                                        absl::string_view where) {
  StepRecord r;
  RETURN_IF_ERROR(ReadString(s, where, "step", kMaxNameBytes, &r.step));
  RETURN_IF_ERROR(
      ReadString(s, where, "input_hash", kMaxNameBytes, &r.input_hash));
  RETURN_IF_ERROR(ReadBool(s, where, "computed", &r.computed));
  ASSIGN_OR_RETURN(r.artifacts, ArtifactsFromJson(s, where, true));
  double seconds = 0;
  ASSIGN_OR_RETURN(const json* has_seconds, Member(s, where, "seconds", false));
  if (has_seconds != nullptr) {
    RETURN_IF_ERROR(ReadNumber(s, where, "seconds", 0, kMaxNumber, &seconds));
    r.seconds = seconds;
  }
  return r;
}

absl::StatusOr<JobResult> ResultFromJson(const json& j) {
  JobResult result;
  std::string code, message;
  RETURN_IF_ERROR(ReadString(j, "", "code", kMaxNameBytes, &code));
  RETURN_IF_ERROR(ReadString(j, "", "message", kMaxTextBytes, &message));
  result.status = absl::Status(ParseStatusCode(code), message);
  ASSIGN_OR_RETURN(const json* steps, ReadArray(j, "", "steps", kMaxSteps));
  for (size_t i = 0; i < steps->size(); ++i) {
    ASSIGN_OR_RETURN(StepRecord r,
                     StepFromJson((*steps)[i], Index("steps", i)));
    result.steps.push_back(std::move(r));
  }
  return result;
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

absl::StatusOr<JobRequest> ParseJobRequest(absl::string_view json_text,
                                           const fs::path& session_dir) {
  constexpr absl::string_view kWhat = "pipeline job request";
  ASSIGN_OR_RETURN(const json j, ParseObject(json_text, kWhat));
  absl::StatusOr<JobRequest> request = RequestFromJson(j, session_dir);
  if (!request.ok()) return NotA(kWhat, request.status());
  return request;
}

absl::StatusOr<JobRequest> ReadJobRequest(const fs::path& job_dir,
                                          const fs::path& session_dir) {
  const fs::path path = job_dir / kJobRequestFile;
  ASSIGN_OR_RETURN(const std::string text,
                   ReadDocument(path, "pipeline job request"));
  return io::WithSource(path.string(), ParseJobRequest(text, session_dir));
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

absl::StatusOr<JobResult> ParseJobResult(absl::string_view json_text) {
  constexpr absl::string_view kWhat = "pipeline job result";
  ASSIGN_OR_RETURN(const json j, ParseObject(json_text, kWhat));
  absl::StatusOr<JobResult> result = ResultFromJson(j);
  if (!result.ok()) return NotA(kWhat, result.status());
  return result;
}

absl::StatusOr<JobResult> ReadJobResult(const fs::path& job_dir) {
  const fs::path path = job_dir / kJobResultFile;
  ASSIGN_OR_RETURN(const std::string text,
                   ReadDocument(path, "pipeline job result"));
  return io::WithSource(path.string(), ParseJobResult(text));
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
