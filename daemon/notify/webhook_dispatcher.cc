// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/notify/webhook_dispatcher.h"

#include <curl/curl.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <memory>
#include <mutex>
#include <vector>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::notify {
namespace {

// Batches keep each transaction short.
constexpr int kBatch = 100;
// What an error message keeps of a refusing receiver's body.
constexpr size_t kMaxResponseExcerpt = 200;

struct CurlDeleter {
  void operator()(CURL* curl) const { curl_easy_cleanup(curl); }
};
struct HeadersDeleter {
  void operator()(curl_slist* list) const { curl_slist_free_all(list); }
};

size_t KeepExcerpt(char* data, size_t size, size_t count, void* out) {
  auto* text = static_cast<std::string*>(out);
  const size_t bytes = size * count;
  if (text->size() < kMaxResponseExcerpt) {
    text->append(data, std::min(bytes, kMaxResponseExcerpt - text->size()));
  }
  return bytes;
}

// Non-zero aborts the transfer: the daemon is stopping.
int AbortOnStop(void* stop, curl_off_t, curl_off_t, curl_off_t, curl_off_t) {
  return static_cast<std::atomic<bool>*>(stop)->load() ? 1 : 0;
}

std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0) return "unknown";
  return name;
}

int64_t NowMs() { return absl::ToUnixMillis(absl::Now()); }

}  // namespace

WebhookDispatcher::WebhookDispatcher(store::Store& store,
                                     const WebhookSigner& signer,
                                     jobs::JobEngine& engine,
                                     WebhookDispatcherOptions options)
    : store_(store),
      hooks_(store),
      signer_(signer),
      engine_(engine),
      options_(std::move(options)),
      daemon_host_(options_.daemon_host.empty() ? HostName()
                                                : options_.daemon_host) {}

WebhookDispatcher::~WebhookDispatcher() { Stop(); }

absl::Status WebhookDispatcher::Start() {
  static std::once_flag curl_init;
  std::call_once(curl_init, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
  ASSIGN_OR_RETURN(cursor_, hooks_.JobEventCursor());
  thread_ = std::thread([this] { Loop(); });
  return absl::OkStatus();
}

void WebhookDispatcher::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void WebhookDispatcher::Loop() {
  std::string last_error;
  while (!stop_) {
    const int64_t generation = engine_.event_generation();
    absl::Status status = Collect();
    if (status.ok()) status = DeliverDue();
    // A broken database would repeat its error every poll: log changes.
    if (!status.ok() && status.ToString() != last_error) {
      spdlog::error("webhooks: {}", status.ToString());
    }
    last_error = status.ok() ? "" : status.ToString();
    absl::Time wake = absl::Now() + options_.poll;
    if (absl::StatusOr<std::optional<int64_t>> due = hooks_.NextDue();
        due.ok() && due->has_value()) {
      wake = std::min(wake, absl::FromUnixMillis(**due));
    }
    if (engine_.stopping()) {
      std::unique_lock<std::mutex> lock(mutex_);
      stop_cv_.wait_until(lock, absl::ToChronoTime(wake),
                          [this] { return stop_.load(); });
    } else {
      engine_.WaitForEvents(generation, wake);
    }
  }
}

absl::Status WebhookDispatcher::Collect() {
  store::JobRepository jobs(store_);
  store::ScheduleRepository schedules(store_);
  while (!stop_) {
    ASSIGN_OR_RETURN(std::vector<store::JobEventRow> events,
                     jobs.EventsAfterRow(cursor_, kBatch));
    ASSIGN_OR_RETURN(std::vector<store::ScheduleRunRecord> runs,
                     schedules.UnannouncedRuns(kBatch));
    if (events.empty() && runs.empty()) return absl::OkStatus();
    ASSIGN_OR_RETURN(std::vector<store::WebhookRecord> hooks, hooks_.List());
    std::vector<store::OutboxEntry> entries;
    auto queue = [&](const std::string& id, const std::string& type,
                     const std::string& body) {
      for (const store::WebhookRecord& hook : hooks) {
        if (FilterMatches(hook.events, type)) {
          entries.push_back({.webhook_id = hook.id,
                             .event_id = id,
                             .type = type,
                             .body = body});
        }
      }
    };
    int64_t cursor = cursor_;
    for (const store::JobEventRow& row : events) {
      cursor = row.row_id;
      std::optional<std::string> type = JobEventType(row);
      if (!type) continue;
      queue(JobEventId(row), *type, JobEventBody(row, *type, daemon_host_));
    }
    std::vector<int64_t> announced;
    for (const store::ScheduleRunRecord& run : runs) {
      announced.push_back(run.id);
      queue(ScheduleRunEventId(run), ScheduleRunEventType(run),
            ScheduleRunBody(run, daemon_host_));
    }
    RETURN_IF_ERROR(hooks_.Enqueue(entries, cursor, announced, NowMs()));
    cursor_ = cursor;
  }
  return absl::OkStatus();
}

absl::Status WebhookDispatcher::DeliverDue() {
  ASSIGN_OR_RETURN(std::vector<store::DueDelivery> due,
                   hooks_.Due(NowMs(), kBatch));
  for (const store::DueDelivery& delivery : due) {
    if (stop_) break;
    ASSIGN_OR_RETURN(std::string secret, signer_.SecretFor(delivery.salt_hex));
    ASSIGN_OR_RETURN(std::string signature,
                     SignatureHeaderValue(secret, delivery.body));
    const absl::Time start = absl::Now();
    const Response response = Post(delivery, signature);
    const absl::Time end = absl::Now();
    // A request the daemon's stop aborted is not an attempt.
    if (stop_ && !response.error.empty()) break;
    const int attempt = delivery.attempts + 1;
    store::OutboxState state = store::OutboxState::kDelivered;
    int64_t next_ms = 0;
    if (!response.error.empty()) {
      std::optional<absl::Duration> delay =
          RetryDelay(options_.retry, attempt, response.http_status);
      state =
          delay ? store::OutboxState::kPending : store::OutboxState::kAbandoned;
      next_ms = delay ? absl::ToUnixMillis(end + *delay) : 0;
      spdlog::warn(
          "webhook {} ({}): {} {} attempt {} failed: {}; {}",
          delivery.webhook_id, UrlOrigin(delivery.url), delivery.type,
          delivery.event_id, attempt, response.error,
          delay ? absl::StrCat("retrying in ", absl::FormatDuration(*delay))
                : std::string("giving up"));
    }
    RETURN_IF_ERROR(hooks_.RecordAttempt(delivery, absl::ToUnixMillis(start),
                                         absl::ToInt64Milliseconds(end - start),
                                         response.http_status, response.error,
                                         state, next_ms));
  }
  return absl::OkStatus();
}

WebhookDispatcher::Response WebhookDispatcher::Post(
    const store::DueDelivery& delivery, absl::string_view signature) {
  Response response;
  std::unique_ptr<CURL, CurlDeleter> curl(curl_easy_init());
  if (curl == nullptr) {
    response.error = "libcurl could not start a request";
    return response;
  }
  curl_slist* list = nullptr;
  for (const std::string& header : {
           std::string("Content-Type: application/json"),
           absl::StrCat("X-Hdrstereo-Event: ", delivery.type),
           absl::StrCat("X-Hdrstereo-Event-Id: ", delivery.event_id),
           absl::StrCat("X-Hdrstereo-Attempt: ", delivery.attempts + 1),
           absl::StrCat("X-Hdrstereo-Signature: ", signature),
       }) {
    list = curl_slist_append(list, header.c_str());
  }
  std::unique_ptr<curl_slist, HeadersDeleter> headers(list);
  std::string excerpt;
  CURL* c = curl.get();
  curl_easy_setopt(c, CURLOPT_URL, delivery.url.c_str());
  curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 0L);
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(c, CURLOPT_USERAGENT, "hdrstereod");
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers.get());
  curl_easy_setopt(c, CURLOPT_POSTFIELDS, delivery.body.c_str());
  curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE_LARGE,
                   static_cast<curl_off_t>(delivery.body.size()));
  curl_easy_setopt(
      c, CURLOPT_CONNECTTIMEOUT_MS,
      static_cast<long>(absl::ToInt64Milliseconds(options_.connect_timeout)));
  curl_easy_setopt(
      c, CURLOPT_TIMEOUT_MS,
      static_cast<long>(absl::ToInt64Milliseconds(options_.request_timeout)));
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, KeepExcerpt);
  curl_easy_setopt(c, CURLOPT_WRITEDATA, &excerpt);
  curl_easy_setopt(c, CURLOPT_NOPROGRESS, 0L);
  curl_easy_setopt(c, CURLOPT_XFERINFOFUNCTION, AbortOnStop);
  curl_easy_setopt(c, CURLOPT_XFERINFODATA, &stop_);
  const CURLcode code = curl_easy_perform(c);
  long http = 0;
  curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &http);
  response.http_status = static_cast<int>(http);
  if (code != CURLE_OK) {
    response.error = curl_easy_strerror(code);
  } else if (http < 200 || http >= 300) {
    response.error = absl::StrCat("HTTP ", http);
    if (!excerpt.empty()) {
      absl::StrAppend(&response.error, ": ", absl::CHexEscape(excerpt));
    }
  }
  return response;
}

}  // namespace hdrstereo::notify
