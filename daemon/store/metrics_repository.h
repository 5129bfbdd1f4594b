// SPDX-License-Identifier: GPL-3.0-or-later
//
// The totals the metrics endpoint reports, read in one pass over the store.
#ifndef HDRSTEREO_DAEMON_STORE_METRICS_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_METRICS_REPOSITORY_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "daemon/store/event_kind.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct StoreTotals {
  std::map<std::string, int64_t> jobs_by_state;  // every state, 0 included
  int64_t frames = 0;
  // Frames whose row holds what the camera reported (its file name or EXIF
  // exposure): those went through verification.
  int64_t frames_verified = 0;
  // Job events that suspended a job: their message starts "suspended".
  int64_t suspensions = 0;
  // Seconds between consecutive frames of a capture job (from its job
  // events' progress), one entry per frame after the first.
  std::vector<double> frame_seconds;
  // Job events by kind: every kind of the verification failure and device
  // error families, 0 included.
  std::map<EventKind, int64_t> events_by_kind;
  // Seconds of each device call capture jobs timed, by device (every
  // device, empty included).
  std::map<Device, std::vector<double>> device_seconds;
  // Seconds of each computed processing step, by step name.
  std::map<std::string, std::vector<double>> step_seconds;
};

class MetricsRepository {
 public:
  explicit MetricsRepository(Store& store) : store_(store) {}
  absl::StatusOr<StoreTotals> Read();

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_METRICS_REPOSITORY_H_
