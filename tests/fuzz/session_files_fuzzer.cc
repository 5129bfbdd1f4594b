// SPDX-License-Identifier: GPL-3.0-or-later
// What a cluster node writes into a session folder for the daemon to take
// in: result.json, the pipeline's pipeline_state.json and metrics, and
// request.json (the daemon's own, read back on the node). A node must not
// be able to name a file outside the session folder.
#include <string>

#include "processing/pipeline/session_files.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

void CheckRelative(const std::string& path) {
  FUZZ_CHECK(!path.empty() && path.front() != '/');
  FUZZ_CHECK(path != ".." && path.rfind("../", 0) != 0 &&
             path.find("/../") == std::string::npos &&
             (path.size() < 3 || path.compare(path.size() - 3, 3, "/..") != 0));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace pipeline = hdrstereo::pipeline;
  const absl::string_view text = hdrstereo::fuzz::AsText(data, size);
  absl::StatusOr<pipeline::JobResult> result = pipeline::ParseJobResult(text);
  if (result.ok()) {
    for (const pipeline::StepRecord& step : result->steps) {
      for (const pipeline::Artifact& artifact : step.artifacts) {
        CheckRelative(artifact.path);
      }
    }
  }
  absl::StatusOr<pipeline::JobRequest> request =
      pipeline::ParseJobRequest(text, "/session");
  if (request.ok()) {
    for (const pipeline::FrameInput& frame : request->input.frames) {
      CheckRelative(frame.path);
    }
  }
  absl::StatusOr<pipeline::JsonRunStore> state =
      pipeline::JsonRunStore::Parse(text, "/session/pipeline_state.json");
  if (state.ok()) {
    for (const std::string& step : state->StepNames()) {
      const auto entry = state->Entry(step);
      FUZZ_CHECK(entry.has_value());
      for (const pipeline::Artifact& artifact : entry->second) {
        CheckRelative(artifact.path);
      }
    }
  }
  (void)pipeline::MetricsFromJson(text);
  return 0;
}
