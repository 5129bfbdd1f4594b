// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Prometheus text endpoint (--metrics-listen). Every value is read from
// the store (and statvfs) when it is scraped, so the metrics need no hooks
// in the jobs and cannot drift from what the database records.
#ifndef HDRSTEREO_DAEMON_METRICS_METRICS_EXPORTER_H_
#define HDRSTEREO_DAEMON_METRICS_METRICS_EXPORTER_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "daemon/jobs/disk_guard.h"
#include "daemon/store/store.h"

namespace prometheus {
class Exposer;
}  // namespace prometheus

namespace hdrstereo::metrics {

class StoreCollector;

class MetricsExporter {
 public:
  // Serves GET /metrics on `address` (HOST:PORT; port 0 picks one).
  // UNAVAILABLE naming the address when it cannot be bound (e.g. the port
  // is taken): the daemon then refuses to start rather than run unobserved.
  static absl::StatusOr<std::unique_ptr<MetricsExporter>> Start(
      const std::string& address, store::Store& store,
      const jobs::DiskGuard& disk_guard);
  ~MetricsExporter();

  int port() const { return port_; }

 private:
  MetricsExporter(std::unique_ptr<prometheus::Exposer> exposer,
                  std::shared_ptr<StoreCollector> collector, int port);

  // The exposer (its threads call the collector) goes first.
  std::shared_ptr<StoreCollector> collector_;
  std::unique_ptr<prometheus::Exposer> exposer_;
  int port_;
};

}  // namespace hdrstereo::metrics

#endif  // HDRSTEREO_DAEMON_METRICS_METRICS_EXPORTER_H_
