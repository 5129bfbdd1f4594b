// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/device_time_repository.h"

#include "daemon/store/database.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {

absl::Status DeviceTimeRepository::Record(
    int64_t job_id, const std::vector<DeviceTimeSample>& samples) {
  if (samples.empty()) return absl::OkStatus();
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  for (const DeviceTimeSample& sample : samples) {
    ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO device_time (job_id, device, seconds, time_ms)
VALUES (?1, ?2, ?3, ?4))sql"));
    RETURN_IF_ERROR(insert.Bind(1, job_id)
                        .Bind(2, DeviceName(sample.device))
                        .Bind(3, sample.seconds)
                        .Bind(4, sample.time_ms)
                        .Run());
  }
  return tx.Commit();
}

}  // namespace hdrstereo::store
