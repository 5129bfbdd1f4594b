// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/gphoto2_opener.h"

#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::gphoto2 {

Gphoto2Opener::Gphoto2Opener(Gphoto2Options options,
                             Gphoto2Camera::ApiFactory new_api)
    : options_(std::move(options)), new_api_(std::move(new_api)) {}

absl::Status Gphoto2Opener::PreviousHandleLetGo() {
  if (!previous_) return absl::OkStatus();
  const std::optional<HandleUse> use = previous_();
  if (use.has_value()) {
    // Negative infinity when no call is stuck: waited for without a bound.
    const absl::Duration stuck_for = absl::Now() - use->stuck_since;
    // A network camera's stuck call holds a TCP connection, not the
    // device: a new connection replaces it (see the header).
    const absl::Duration wait = IsNetworkPort(options_.port)
                                    ? absl::ZeroDuration()
                                    : options_.stuck_handle_wait;
    if (stuck_for < wait) {
      if (use->stuck_call.empty()) {
        return absl::UnavailableError(
            "the camera's previous connection is still in use; it is "
            "reopened once that call returns");
      }
      return absl::UnavailableError(absl::StrCat(
          "the camera's previous connection is still stuck in \"",
          use->stuck_call, "\", which timed out ",
          absl::FormatDuration(absl::Trunc(stuck_for, absl::Milliseconds(1))),
          " ago; it is reopened once libgphoto2 returns, or in ",
          absl::FormatDuration(
              absl::Trunc(wait - stuck_for, absl::Milliseconds(1))),
          " regardless"));
    }
  }
  previous_ = nullptr;
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Gphoto2Opener::Open() {
  RETURN_IF_ERROR(PreviousHandleLetGo());
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      opened_once_ ? Gphoto2Camera::Reopen(options_, serial_, new_api_)
                   : Gphoto2Camera::OpenWithApi(options_, new_api_());
  if (!camera.ok()) return camera;
  if (!opened_once_) {
    opened_once_ = true;
    options_.model = (*camera)->model();
    absl::StatusOr<hardware::CameraInfo> info = (*camera)->Info();
    serial_ = info.ok() ? info->serial : "";
  }
  previous_ = (*camera)->WatchHandle();
  return camera;
}

std::function<absl::StatusOr<std::unique_ptr<hardware::Camera>>()>
CameraOpenerOf(std::shared_ptr<Gphoto2Opener> opener) {
  return [opener = std::move(
              opener)]() -> absl::StatusOr<std::unique_ptr<hardware::Camera>> {
    ASSIGN_OR_RETURN(std::unique_ptr<Gphoto2Camera> camera, opener->Open());
    return std::unique_ptr<hardware::Camera>(std::move(camera));
  };
}

}  // namespace hdrstereo::gphoto2
