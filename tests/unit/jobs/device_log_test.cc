// SPDX-License-Identifier: GPL-3.0-or-later
//
// Which device errors a capture takes its frame again after
// (IsTransientDeviceError), on the errors as the drivers return them and
// DeviceLog marks them.
#include "daemon/jobs/device_log.h"

#include <gtest/gtest.h>

#include <vector>

#include "hardware/stage.h"

namespace hdrstereo::jobs {
namespace {

using store::Device;

// `status` as DeviceLog returns it from a call on `device`.
absl::Status Marked(Device device, const absl::Status& status) {
  return store::WithEventKind(status, DeviceErrorKind(device, status));
}

// Timeouts, a busy camera, garbled or missing stage replies, a stalled
// move, a fault flag and a pattern that did not get on screen may pass; a
// camera that dropped (waited for as a drop) and errors that do not pass by
// themselves are permanent.
TEST(DeviceLogTest, TransientAndPermanentErrorsByDeviceAndCode) {
  struct Case {
    Device device;
    absl::Status status;
    bool transient;
  };
  for (const Case& c : std::vector<Case>{
           {Device::kCamera, absl::DeadlineExceededError("timed out"), true},
           {Device::kCamera, absl::UnavailableError("camera is busy"), true},
           {Device::kStage, absl::DataLossError("with garbage"), true},
           {Device::kStage, absl::DeadlineExceededError("no answer"), true},
           {Device::kStage, hardware::StalledError("did not finish"), true},
           {Device::kStage, absl::AbortedError("stage reports FS"), true},
           {Device::kProjector, absl::UnavailableError("unmapped"), true},
           {Device::kProjector, absl::DeadlineExceededError("slow"), true},
           {Device::kCamera,
            absl::AbortedError("camera disconnected during transfer"), false},
           {Device::kCamera, absl::InvalidArgumentError("no shutter"), false},
           {Device::kCamera, absl::ResourceExhaustedError("card full"), false},
           {Device::kCamera, absl::UnknownError("gphoto2 error [-1]"), false},
           {Device::kStage, absl::FailedPreconditionError("rejected"), false},
           {Device::kStage, absl::UnavailableError("port gone"), false},
           {Device::kStage, absl::InvalidArgumentError("off travel"), false},
           {Device::kProjector, absl::InvalidArgumentError("size"), false},
           {Device::kProjector, absl::InternalError("XCreateImage"), false}}) {
    EXPECT_EQ(IsTransientDeviceError(Marked(c.device, c.status)), c.transient)
        << store::DeviceName(c.device) << ": " << c.status;
  }
  // Not from a device call (no device error kind): never taken again.
  EXPECT_FALSE(IsTransientDeviceError(absl::DeadlineExceededError("x")));
}

}  // namespace
}  // namespace hdrstereo::jobs
