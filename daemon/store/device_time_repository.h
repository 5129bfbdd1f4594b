// SPDX-License-Identifier: GPL-3.0-or-later
//
// How long the device calls of capture jobs took (table `device_time`):
// one row per capture, stage move or projector pattern, for the metrics'
// device-time histogram.
#ifndef HDRSTEREO_DAEMON_STORE_DEVICE_TIME_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_DEVICE_TIME_REPOSITORY_H_

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "daemon/store/event_kind.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct DeviceTimeSample {
  Device device = Device::kCamera;
  double seconds = 0;
  int64_t time_ms = 0;  // when the call ended
};

class DeviceTimeRepository {
 public:
  explicit DeviceTimeRepository(Store& store) : store_(store) {}

  // Records `samples` of job `job_id` in one transaction.
  absl::Status Record(int64_t job_id,
                      const std::vector<DeviceTimeSample>& samples);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_DEVICE_TIME_REPOSITORY_H_
