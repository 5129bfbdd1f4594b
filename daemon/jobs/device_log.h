// SPDX-License-Identifier: GPL-3.0-or-later
//
// The device calls of one capture job: how long they took and, for a call
// that failed, what kind of device error it was.
//
// Every call counts to total() (the job's "in the devices" summary). A
// capture, a stage move and a projector pattern are also one sample each
// of the device-time histogram: samples are recorded in the store
// (store::DeviceTimeRepository) in batches, at most kFlushInterval after
// the call and when the log is destroyed, so that timing a call costs no
// transaction of its own. An error a call returns is marked with its
// device error kind (store::WithEventKind), which the job's final event
// records when the error fails the job.
#ifndef HDRSTEREO_DAEMON_JOBS_DEVICE_LOG_H_
#define HDRSTEREO_DAEMON_JOBS_DEVICE_LOG_H_

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "daemon/store/device_time_repository.h"
#include "daemon/store/event_kind.h"
#include "daemon/store/store.h"

namespace hdrstereo::jobs {

// The device error kind of `status` (not OK), returned by a call on
// `device`: from its code, as the hardware interfaces document them (a
// camera that dropped, hardware::IsCameraGone; a stalled stage,
// hardware::IsStalled).
store::EventKind DeviceErrorKind(store::Device device,
                                 const absl::Status& status);

// The result of a call on `device`, an error marked with its device error
// kind (as DeviceLog marks the calls it times; IsTransientDeviceError reads
// the mark). For calls made outside a capture's DeviceLog.
absl::Status MarkDeviceError(store::Device device, absl::Status status);
template <typename T>
absl::StatusOr<T> MarkDeviceError(store::Device device,
                                  absl::StatusOr<T> result) {
  if (result.ok()) return result;
  return MarkDeviceError(device, result.status());
}

// Whether `status`, the error of a device call that DeviceLog marked with
// its kind, may pass when the call is made again: a camera that timed out
// or stayed busy past the driver's own retries; a stage whose replies were
// garbled or missing past the driver's resends, whose move stalled, or
// which raised a fault flag; a projector whose pattern did not get on
// screen (UNAVAILABLE, DEADLINE_EXCEEDED). Not a camera that dropped (its
// reconnect is waited for), nor anything else: a setting the camera does
// not offer, a command the stage rejects, a serial port that is gone, an
// error not from a device call (unmarked) are permanent.
bool IsTransientDeviceError(const absl::Status& status);

class DeviceLog {
 public:
  static constexpr absl::Duration kFlushInterval = absl::Seconds(5);

  DeviceLog(store::Store& store, int64_t job_id)
      : repository_(store), job_id_(job_id) {}
  ~DeviceLog();  // records what is left
  DeviceLog(const DeviceLog&) = delete;
  DeviceLog& operator=(const DeviceLog&) = delete;

  // Runs `call` on `device`; it returns absl::Status or absl::StatusOr<T>.
  template <typename Call>
  auto Time(store::Device device, Call&& call) {
    return Run(device, /*sample=*/false, call);
  }
  // The same, and the call is one sample of the device-time histogram.
  template <typename Call>
  auto Sample(store::Device device, Call&& call) {
    return Run(device, /*sample=*/true, call);
  }
  // A wait the devices need (a stage settling): counts to total().
  void Wait(absl::Duration wait);

  absl::Duration total() const { return total_; }

 private:
  static const absl::Status& StatusOf(const absl::Status& s) { return s; }
  template <typename T>
  static const absl::Status& StatusOf(const absl::StatusOr<T>& s) {
    return s.status();
  }

  template <typename Call>
  auto Run(store::Device device, bool sample, Call& call) {
    const absl::Time start = absl::Now();
    auto result = call();
    Add(device, sample, start, absl::Now());
    if (!result.ok()) result = MarkDeviceError(device, StatusOf(result));
    return result;
  }
  void Add(store::Device device, bool sample, absl::Time start, absl::Time end);
  // Records the samples not recorded yet; on failure keeps them for the
  // next try (and logs why).
  void Flush();

  store::DeviceTimeRepository repository_;
  const int64_t job_id_;
  absl::Duration total_;
  std::vector<store::DeviceTimeSample> unrecorded_;
  absl::Time last_flush_ = absl::Now();
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_DEVICE_LOG_H_
