// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thin seam between the camera driver and libgphoto2: one camera's
// calls, each returning libgphoto2's own result code (GP_OK or a negative
// GP_ERROR_*). Implemented over the real library in libgphoto2_api.h and by
// a fake with a widget tree in the unit tests, so the driver's mapping, retry
// and error logic runs without a camera.
//
// Calls block. The driver makes every call on one worker thread of its own
// (libgphoto2 camera handles are not thread-safe); only Cancel() may be
// called from another thread, while a call runs.
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_API_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_API_H_

#include <string>
#include <vector>

#include "absl/time/time.h"

namespace hdrstereo::gphoto2 {

struct DetectedCamera {
  std::string model;  // e.g. "Canon EOS 5D Mark III"
  std::string port;   // e.g. "usb:001,004"
};

enum class WidgetType { kText, kRange, kToggle, kRadio, kMenu, kDate, kButton };

// One leaf of the camera's configuration tree (sections are flattened away).
struct ConfigWidget {
  std::string name;   // e.g. "shutterspeed"
  std::string label;  // e.g. "Shutter Speed"
  std::string path;   // e.g. "/main/capturesettings/shutterspeed"
  WidgetType type = WidgetType::kText;
  bool read_only = false;
  // The current value as text: the string of text/radio/menu widgets, "%g"
  // of ranges, "0"/"1" of toggles, seconds since the epoch of dates.
  std::string value;
  std::vector<std::string> choices;  // radio and menu widgets
  float min = 0, max = 0, step = 0;  // range widgets
};

enum class EventType { kTimeout, kFileAdded, kCaptureComplete, kOther };

struct CameraEvent {
  EventType type = EventType::kTimeout;
  std::string folder;  // kFileAdded
  std::string name;    // kFileAdded
};

struct FileData {
  std::string bytes;
  absl::Time mtime = absl::InfinitePast();  // unknown if InfinitePast
};

class Gphoto2Api {
 public:
  virtual ~Gphoto2Api() = default;

  // gp_camera_autodetect: the cameras on USB (and other probed ports).
  virtual int Autodetect(std::vector<DetectedCamera>* cameras) = 0;
  // GP_OK when libgphoto2 has a driver for `model` (as its abilities list
  // names it, case-insensitively), whether or not such a camera is
  // connected; GP_ERROR_MODEL_NOT_FOUND otherwise.
  virtual int CheckModel(const std::string& model) = 0;
  // Selects `model` (as libgphoto2's abilities list names it) on `port`
  // ("usb:001,004", "disk:/some/folder", ...) and runs gp_camera_init.
  virtual int Open(const std::string& model, const std::string& port) = 0;

  virtual int GetSummary(std::string* text) = 0;
  // The whole configuration tree, flattened to its leaves.
  virtual int GetConfig(std::vector<ConfigWidget>* widgets) = 0;
  // Sets one widget from text (a choice, a number, "0"/"1").
  virtual int SetConfigValue(const std::string& name,
                             const std::string& value) = 0;
  // gp_camera_capture(GP_CAPTURE_IMAGE): where the new file lies on the
  // camera.
  virtual int Capture(std::string* folder, std::string* name) = 0;
  // gp_camera_capture_preview: one live-view frame (JPEG on the cameras
  // that have live view); the camera enters live view if it is not in it.
  virtual int CapturePreview(FileData* file) = 0;
  // gp_camera_wait_for_event, up to `timeout`.
  virtual int WaitForEvent(absl::Duration timeout, CameraEvent* event) = 0;
  virtual int ListFiles(const std::string& folder,
                        std::vector<std::string>* names) = 0;
  // gp_camera_file_get(GP_FILE_TYPE_NORMAL).
  virtual int GetFile(const std::string& folder, const std::string& name,
                      FileData* file) = 0;
  virtual int DeleteFile(const std::string& folder,
                         const std::string& name) = 0;

  // Asks the call in progress to give up (libgphoto2 polls the context's
  // cancel function between transfer chunks; a call blocked inside one USB
  // transfer returns only when that transfer times out). Thread-safe.
  virtual void Cancel() = 0;
  // Clears a previous Cancel() and the last error text; called before each
  // call.
  virtual void BeginCall() = 0;
  // libgphoto2's text for `code` plus the last error the camera library
  // reported through the context (e.g. "Could not claim the USB device"),
  // for the call just made.
  virtual std::string ErrorText(int code) = 0;
};

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_API_H_
