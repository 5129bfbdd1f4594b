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
// FAILED_PRECONDITION. Live view (CapturePreview) asks a second source, the
// same way, for a live-view frame, and sets the dump's viewfinder toggle
// (kViewfinderWidgets) to 1 as a camera in live view reports it; without
// that source it is GP_ERROR_NOT_SUPPORTED.
//
// Autodetect lists the dump's model on port "replay:<dump file>", and
// libgphoto2 knows that model only (CheckModel).
//
// The camera's USB link is a ReplayLink, which the apis of one replayed
// camera share (the driver makes an api per handle, and a reopen makes new
// ones): it can drop mid-capture and come back. While it is unplugged,
// Autodetect lists no camera and Open fails with GP_ERROR_IO_USB_FIND; an
// api opened before the unplug answers every call with GP_ERROR_IO from
// then on, also after the camera is back, as libgphoto2 does for a handle
// whose USB device went away. A frame source error that says the camera
// went away unplugs the link.
//
// Like the library, a ReplayApi is not thread-safe: the driver makes every
// call on one thread. The link is thread-safe.

#ifndef HDRSTEREO_HARDWARE_GPHOTO2_REPLAY_API_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_REPLAY_API_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
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

// The replayed camera's USB link.
//
//   auto link = std::make_shared<ReplayLink>(
//       [&world] { return world.ReopenCamera(); });  // is it back?
//   ReplayApi api(dump, frames, link);
class ReplayLink {
 public:
  // `plug_in` is asked, under the link's lock, each time the camera is
  // looked for (Autodetect, Open) while it is unplugged: OK plugs it in,
  // an error is why it is not there. The link starts unplugged, so the
  // first look asks too. Without `plug_in` the camera is there whenever it
  // is looked for.
  explicit ReplayLink(std::function<absl::Status()> plug_in = nullptr);

  // Looks for the camera: its connection (1 at the first plug-in, one more
  // at each after an unplug), or why it is not there.
  absl::StatusOr<int64_t> Find();
  // Whether `connection` is still the link's (no unplug since).
  bool Up(int64_t connection) const;
  // The camera drops off the bus.
  void Unplug();

 private:
  const std::function<absl::Status()> plug_in_;
  mutable std::mutex mutex_;
  bool plugged_ = false;
  int64_t connection_ = 0;
};

class ReplayApi final : public Gphoto2Api {
 public:
  // `link` defaults to a link of its own that is always there.
  explicit ReplayApi(CameraDump dump, FrameSource frames = nullptr,
                     std::shared_ptr<ReplayLink> link = nullptr,
                     FrameSource previews = nullptr);

  int Autodetect(std::vector<DetectedCamera>* cameras) override;
  int CheckModel(const std::string& model) override;
  int Open(const std::string& model, const std::string& port) override;
  int GetSummary(std::string* text) override;
  int GetConfig(std::vector<ConfigWidget>* widgets) override;
  int SetConfigValue(const std::string& name,
                     const std::string& value) override;
  int Capture(std::string* folder, std::string* name) override;
  int CapturePreview(FileData* file) override;
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
  // The file `source` makes with the settings now in effect, or the code
  // to fail with.
  int FromSource(const FrameSource& source, ReplayFile* file);
  // GP_OK while the connection this api opened is up, else GP_ERROR_IO.
  int CheckLink();

  const CameraDump dump_;
  const FrameSource frames_;
  const std::shared_ptr<ReplayLink> link_;
  const FrameSource previews_;
  int64_t connection_ = 0;  // the link's, as Open found it; 0: not open
  std::vector<ConfigWidget> widgets_;
  // (folder, name) -> bytes.
  std::map<std::pair<std::string, std::string>, std::string> files_;
  int captures_ = 0;
  std::string last_error_;
};

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_REPLAY_API_H_
