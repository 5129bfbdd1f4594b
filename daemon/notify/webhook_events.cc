// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/notify/webhook_events.h"

#include <curl/curl.h>

#include <algorithm>
#include <memory>

#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "nlohmann/json.hpp"

namespace hdrstereo::notify {
namespace {

using store::JobState;

constexpr absl::string_view kSuspendedPrefix = "suspended: ";
constexpr absl::string_view kResumedPrefix = "resumed: ";
constexpr size_t kMaxUrlBytes = 2048;

std::string Rfc3339(int64_t unix_ms) {
  return absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", absl::FromUnixMillis(unix_ms),
                          absl::UTCTimeZone());
}

// A parsed URL, freed on scope exit.
struct UrlDeleter {
  void operator()(CURLU* url) const { curl_url_cleanup(url); }
};
using Url = std::unique_ptr<CURLU, UrlDeleter>;

// One part of `url`, or "" when it has none.
std::string Part(const Url& url, CURLUPart part) {
  char* text = nullptr;
  if (curl_url_get(url.get(), part, &text, 0) != CURLUE_OK || text == nullptr) {
    return "";
  }
  std::string out(text);
  curl_free(text);
  return out;
}

}  // namespace

const std::vector<std::string>& EventTypes() {
  static const auto* const kTypes = new std::vector<std::string>{
      "job.succeeded",       "job.failed",          "job.cancelled",
      "job.suspended",       "job.resumed",         "schedule_run.succeeded",
      "schedule_run.failed", "schedule_run.skipped"};
  return *kTypes;
}

std::optional<std::string> JobEventType(const store::JobEventRow& row) {
  const store::JobEventRecord& event = row.event;
  if (store::IsFinal(event.state)) {
    if (row.previous_state == event.state) return std::nullopt;
    return absl::StrCat("job.", store::JobStateName(event.state));
  }
  if (event.state == JobState::kPaused &&
      absl::StartsWith(event.message, kSuspendedPrefix)) {
    return "job.suspended";
  }
  if (event.state == JobState::kRunning &&
      absl::StartsWith(event.message, kResumedPrefix)) {
    return "job.resumed";
  }
  return std::nullopt;
}

std::string ScheduleRunEventType(const store::ScheduleRunRecord& run) {
  return absl::StrCat("schedule_run.", store::RunOutcomeName(run.outcome));
}

std::string JobEventId(const store::JobEventRow& row) {
  return absl::StrCat("job-", row.event.job_id, "-event-", row.event.sequence);
}

std::string ScheduleRunEventId(const store::ScheduleRunRecord& run) {
  return absl::StrCat("schedule-run-", run.id);
}

std::string JobEventBody(const store::JobEventRow& row, absl::string_view type,
                         absl::string_view daemon_host) {
  const store::JobRecord& job = row.job;
  nlohmann::json body = {
      {"id", JobEventId(row)},
      {"type", type},
      {"time", Rfc3339(row.event.time_ms)},
      {"daemon", daemon_host},
      {"job",
       {{"id", job.id},
        {"kind",
         job.kind == store::JobKind::kCapture ? "capture" : "processing"},
        {"session", job.session},
        {"state", store::JobStateName(row.event.state)},
        {"message", row.event.message},
        {"progress_done", row.event.progress_done},
        {"progress_total", row.event.progress_total},
        {"step", row.event.step},
        {"submitted_by", job.submitted_by}}}};
  if (row.event.state == JobState::kFailed) body["job"]["error"] = job.error;
  // Replace, not throw, on bytes that are not UTF-8 (a camera's file name).
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string ScheduleRunBody(const store::ScheduleRunRecord& run,
                            absl::string_view daemon_host) {
  nlohmann::json body = {
      {"id", ScheduleRunEventId(run)},
      {"type", ScheduleRunEventType(run)},
      {"time", Rfc3339(run.end_time_ms.value_or(run.due_time_ms))},
      {"daemon", daemon_host},
      {"schedule_run",
       {{"id", run.id},
        {"schedule", run.schedule},
        {"due_time", Rfc3339(run.due_time_ms)},
        {"outcome", store::RunOutcomeName(run.outcome)},
        {"reason", run.reason},
        {"session", run.session},
        {"job_ids", run.job_ids},
        {"caused_by", run.caused_by}}}};
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

absl::StatusOr<std::vector<std::string>> ValidateEventFilter(
    const std::vector<std::string>& filter) {
  std::vector<std::string> out;
  for (const std::string& entry : filter) {
    const bool known = entry == "job.*" || entry == "schedule_run.*" ||
                       std::find(EventTypes().begin(), EventTypes().end(),
                                 entry) != EventTypes().end();
    if (!known) {
      return absl::InvalidArgumentError(absl::StrCat(
          "events: \"", absl::CHexEscape(entry.substr(0, 64)),
          "\" is not an event type; use job.* , schedule_run.* or one of ",
          absl::StrJoin(EventTypes(), ", ")));
    }
    if (std::find(out.begin(), out.end(), entry) == out.end()) {
      out.push_back(entry);
    }
  }
  return out;
}

bool FilterMatches(const std::vector<std::string>& filter,
                   absl::string_view type) {
  if (filter.empty()) return true;
  for (const std::string& entry : filter) {
    if (entry == type) return true;
    if (absl::EndsWith(entry, ".*") &&
        absl::StartsWith(type, entry.substr(0, entry.size() - 1))) {
      return true;
    }
  }
  return false;
}

absl::Status ValidateWebhookUrl(absl::string_view url) {
  if (url.empty()) return absl::InvalidArgumentError("url is empty");
  if (url.size() > kMaxUrlBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("url is longer than ", kMaxUrlBytes, " bytes"));
  }
  Url parsed(curl_url());
  if (parsed == nullptr) return absl::ResourceExhaustedError("out of memory");
  const std::string text(url);
  if (CURLUcode code = curl_url_set(parsed.get(), CURLUPART_URL, text.c_str(),
                                    CURLU_NON_SUPPORT_SCHEME);
      code != CURLUE_OK) {
    return absl::InvalidArgumentError(
        absl::StrCat("url \"", absl::CHexEscape(text.substr(0, 64)),
                     "\" is not a URL: ", curl_url_strerror(code)));
  }
  const std::string scheme = Part(parsed, CURLUPART_SCHEME);
  if (scheme != "http" && scheme != "https") {
    return absl::InvalidArgumentError(absl::StrCat(
        "url scheme \"", absl::CHexEscape(scheme),
        "\" is not supported: a webhook URL starts with http:// or https://"));
  }
  if (Part(parsed, CURLUPART_HOST).empty()) {
    return absl::InvalidArgumentError("url has no host");
  }
  if (!Part(parsed, CURLUPART_USER).empty() ||
      !Part(parsed, CURLUPART_PASSWORD).empty()) {
    return absl::InvalidArgumentError(
        "url must not carry a user name or password: the receiver checks "
        "the signature header instead");
  }
  return absl::OkStatus();
}

std::string UrlOrigin(absl::string_view url) {
  Url parsed(curl_url());
  const std::string text(url);
  if (parsed == nullptr ||
      curl_url_set(parsed.get(), CURLUPART_URL, text.c_str(), 0) != CURLUE_OK) {
    return "(invalid url)";
  }
  std::string origin = absl::StrCat(Part(parsed, CURLUPART_SCHEME), "://",
                                    Part(parsed, CURLUPART_HOST));
  if (std::string port = Part(parsed, CURLUPART_PORT); !port.empty()) {
    absl::StrAppend(&origin, ":", port);
  }
  return origin;
}

std::optional<absl::Duration> RetryDelay(const RetryPolicy& policy,
                                         int failed_attempts, int http_status) {
  const bool permanent = http_status >= 400 && http_status < 500 &&
                         http_status != 408 && http_status != 429;
  if (permanent || failed_attempts >= policy.max_attempts) return std::nullopt;
  absl::Duration delay = policy.first_retry;
  for (int i = 1; i < failed_attempts && delay < policy.max_retry; ++i) {
    delay *= 2;
  }
  return std::min(delay, policy.max_retry);
}

}  // namespace hdrstereo::notify
