// SPDX-License-Identifier: GPL-3.0-or-later
//
// Sends webhooks from a thread of its own: it moves new job events and
// ended schedule runs into the SQLite outbox (webhook_repository.h), then
// POSTs each due event with libcurl, records every attempt, and retries
// with backoff. A capture only ever appends its job events: a slow or dead
// receiver delays other deliveries, never a job.
#ifndef HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_DISPATCHER_H_
#define HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_DISPATCHER_H_

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/notify/webhook_events.h"
#include "daemon/notify/webhook_signing.h"
#include "daemon/store/store.h"
#include "daemon/store/webhook_repository.h"

namespace hdrstereo::notify {

struct WebhookDispatcherOptions {
  RetryPolicy retry;
  absl::Duration connect_timeout = absl::Seconds(5);
  absl::Duration request_timeout = absl::Seconds(10);
  // How often ended schedule runs are looked for (job events wake the
  // dispatcher at once).
  absl::Duration poll = absl::Milliseconds(500);
  std::string daemon_host;  // "daemon" in bodies; empty = this host's name
};

class WebhookDispatcher {
 public:
  WebhookDispatcher(store::Store& store, const WebhookSigner& signer,
                    jobs::JobEngine& engine, WebhookDispatcherOptions options);
  ~WebhookDispatcher();  // Stop()

  // Starts the cursor (first run: at the newest job event) and the thread.
  absl::Status Start();
  // Aborts a request in flight and joins the thread; queued events stay in
  // the outbox for the next start.
  void Stop();

 private:
  struct Response {
    int http_status = 0;  // 0: none
    std::string error;    // "" when 2xx
  };

  void Loop();
  absl::Status Collect();
  absl::Status DeliverDue();
  Response Post(const store::DueDelivery& delivery,
                absl::string_view signature);

  store::Store& store_;
  store::WebhookRepository hooks_;
  const WebhookSigner& signer_;
  jobs::JobEngine& engine_;
  const WebhookDispatcherOptions options_;
  std::string daemon_host_;
  int64_t cursor_ = 0;  // the outbox's job-event cursor (only Loop() moves it)

  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable stop_cv_;
  std::thread thread_;
};

}  // namespace hdrstereo::notify

#endif  // HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_DISPATCHER_H_
