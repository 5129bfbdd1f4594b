// SPDX-License-Identifier: GPL-3.0-or-later
//
// A replay camera: the Gphoto2Api seam answered from a recorded
// `gphoto2 --summary --list-all-config` dump instead of a camera, so the
// real driver (Gphoto2Camera: widget lookup, nearest-choice mapping,
// read-back, capture, download, delete) runs against any of the cameras
// libgphoto2's users have recorded. Settings behave as on the camera:
// a radio or menu widget takes one of its choices, a range widget a number
// within its bounds, a toggle 0 or 1, a date a number of seconds; read-only
// widgets refuse (GP_ERROR_NOT_SUPPORTED), as do unknown names and values
// (GP_ERROR_BAD_PARAMETERS). A capture asks a FrameSource for the file the
// camera would deliver with the settings now in effect (e.g. a simulated
// frame); without one, Capture is GP_ERROR_NOT_SUPPORTED. A source error is
// GP_ERROR, or GP_ERROR_IO (a camera gone from USB) when it is ABORTED or
// FAILED_PRECONDITION.
//
// Autodetect lists the dump's model on port "replay:<dump file>", and
// libgphoto2 knows that model only (CheckModel). Like the
// library, not thread-safe: the driver makes every call on one thread.
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_REPLAY_API_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_REPLAY_API_H_

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "hardware/camera.h"
#include "hardware/gphoto2/config_dump.h"
#include "hardware/gphoto2/gphoto2_api.h"

namespace hdrstereo::gphoto2 {

struct ReplayFile {
  std::string bytes;
  std::string extension;  // "jpg", "dng", ...
};

// Makes the file of one capture from the settings the widgets stand for
// (ReadExposureSettings).
using FrameSource = std::function<absl::StatusOr<ReplayFile>(
    const hardware::ExposureSettings& settings)>;

class ReplayApi final : public Gphoto2Api {
 public:
  explicit ReplayApi(CameraDump dump, FrameSource frames = nullptr);

  int Autodetect(std::vector<DetectedCamera>* cameras) override;
  int CheckModel(const std::string& model) override;
  int Open(const std::string& model, const std::string& port) override;
  int GetSummary(std::string* text) override;
  int GetConfig(std::vector<ConfigWidget>* widgets) override;
  int SetConfigValue(const std::string& name,
                     const std::string& value) override;
  int Capture(std::string* folder, std::string* name) override;
  int WaitForEvent(absl::Duration timeout, CameraEvent* event) override;
  int ListFiles(const std::string& folder,
                std::vector<std::string>* names) override;
  int GetFile(const std::string& folder, const std::string& name,
              FileData* file) override;
  int DeleteFile(const std::string& folder, const std::string& name) override;
  void Cancel() override {}
  void BeginCall() override;
  std::string ErrorText(int code) override;

  // "replay:<source>".
  std::string Port() const;

 private:
  // Where a capture lands: RAM captures come from "/", as on a camera;
  // otherwise the card's folder.
  static constexpr const char* kRamFolder = "/";
  static constexpr const char* kCardFolder = "/store_00010001/DCIM/100REPLY";

  // Sets last_error_ and returns `code`.
  int Fail(int code, std::string text);

  const CameraDump dump_;
  const FrameSource frames_;
  std::vector<ConfigWidget> widgets_;
  // (folder, name) -> bytes.
  std::map<std::pair<std::string, std::string>, std::string> files_;
  int captures_ = 0;
  std::string last_error_;
};

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_REPLAY_API_H_
