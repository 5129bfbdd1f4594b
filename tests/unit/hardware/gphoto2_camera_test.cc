// SPDX-License-Identifier: GPL-3.0-or-later
//
// The driver's mapping, retry, timeout and error logic against a fake
// libgphoto2 (a widget tree, files, scripted result codes, hanging calls).
#include "hardware/gphoto2/gphoto2_camera.h"

#include <gmock/gmock.h>
#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "hardware/gphoto2/gphoto2_opener.h"
#include "hardware/reconnecting_camera.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::gphoto2 {
namespace {

using hardware::ImageFormat;
using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

// What the fake camera is and does; shared by the test and the fake (which
// the camera owns and may outlive the test's view of it).
struct FakeState {
  std::mutex mutex;
  std::condition_variable cv;

  std::vector<DetectedCamera> detected = {
      {"Canon EOS 5D Mark III", "usb:001,004"}};
  std::set<std::string> unknown_models;  // libgphoto2 has no driver for
  int open_result = GP_OK;
  // Apis with an open camera handle, now and at most at once.
  int open_handles = 0;
  int max_open_handles = 0;
  std::string error_text;  // what ErrorText() adds to libgphoto2's text
  std::string opened_model, opened_port;
  // Several cameras on one bus: the serial number each api reads, by the
  // port it opened (none: the widgets' own).
  std::map<std::string, std::string> serial_by_port;
  int config_result = GP_OK;
  std::vector<ConfigWidget> widgets;
  std::set<std::string> ignored;  // widgets that keep their value when set
  std::vector<std::pair<std::string, std::string>> sets;

  // Files on the camera by "folder/name"; what a capture produces (the first
  // is returned, the rest announced as events).
  std::map<std::string, std::string> files;
  std::vector<std::pair<std::string, std::string>> capture_produces;
  std::deque<CameraEvent> events;
  std::vector<std::string> deleted;
  // Live view: what a preview delivers. A preview sets the viewfinder
  // toggle (kViewfinderWidgets) to 1, as cameras report live view; while it
  // is 1 a capture fails as with the mirror up (libgphoto2#247).
  std::string preview_bytes = "\xff\xd8 live view";

  // Result codes to return, in order, before an operation behaves normally.
  std::map<std::string, std::deque<int>> scripted;
  std::map<std::string, int> calls;

  // An operation that blocks until released (or cancelled, if it honours
  // cancellation, like libgphoto2 between transfer chunks).
  std::string hang_op;
  bool hang_honours_cancel = false;
  bool released = false;
  bool cancel_requested = false;
  int cancels = 0;
  bool hanging = false;
  bool api_destroyed = false;

  void Release() {
    std::lock_guard<std::mutex> lock(mutex);
    released = true;
    cv.notify_all();
  }
};

ConfigWidget Radio(const std::string& name, const std::string& value,
                   std::vector<std::string> choices) {
  ConfigWidget widget;
  widget.name = name;
  widget.path = "/main/" + name;
  widget.type = WidgetType::kRadio;
  widget.value = value;
  widget.choices = std::move(choices);
  return widget;
}

ConfigWidget Toggle(const std::string& name, const std::string& value) {
  ConfigWidget widget;
  widget.name = name;
  widget.path = "/main/actions/" + name;
  widget.type = WidgetType::kToggle;
  widget.value = value;
  return widget;
}

ConfigWidget Text(const std::string& name, const std::string& value) {
  ConfigWidget widget;
  widget.name = name;
  widget.path = "/main/status/" + name;
  widget.read_only = true;
  widget.value = value;
  return widget;
}

std::vector<ConfigWidget> CanonWidgets() {
  return {
      Radio("shutterspeed", "1/60",
            {"bulb",  "30",    "15",     "8",      "4",      "2",     "1",
             "0.5",   "1/4",   "1/8",    "1/15",   "1/30",   "1/60",  "1/125",
             "1/250", "1/500", "1/1000", "1/2000", "1/4000", "1/8000"}),
      Radio("iso", "400", {"Auto", "100", "200", "400", "800"}),
      Radio("aperture", "4", {"4", "5.6", "8", "11"}),
      Radio("imageformat", "Large Fine JPEG",
            {"Large Fine JPEG", "Large Normal JPEG", "Small Fine JPEG", "mRAW",
             "RAW + Large Fine JPEG", "RAW"}),
      Radio("capturetarget", "Memory card", {"Internal RAM", "Memory card"}),
      Text("cameramodel", "Canon EOS 5D Mark III"),
      Text("serialnumber", "0123456789"),
      Text("batterylevel", "75%"),
  };
}

class FakeApi final : public Gphoto2Api {
 public:
  explicit FakeApi(std::shared_ptr<FakeState> state)
      : state_(std::move(state)) {}
  ~FakeApi() override {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->api_destroyed = true;
    if (!port_.empty()) --state_->open_handles;
    state_->cv.notify_all();
  }

  int Autodetect(std::vector<DetectedCamera>* cameras) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("autodetect", lock); code != GP_OK) return code;
    *cameras = state_->detected;
    return GP_OK;
  }
  int CheckModel(const std::string& model) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("check_model", lock); code != GP_OK) return code;
    return state_->unknown_models.count(model) ? GP_ERROR_MODEL_NOT_FOUND
                                               : GP_OK;
  }
  int Open(const std::string& model, const std::string& port) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("open", lock); code != GP_OK) return code;
    if (state_->open_result != GP_OK) return state_->open_result;
    state_->opened_model = model;
    state_->opened_port = port;
    port_ = port;
    state_->max_open_handles =
        std::max(state_->max_open_handles, ++state_->open_handles);
    return GP_OK;
  }
  int GetSummary(std::string* text) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("summary", lock); code != GP_OK) return code;
    *text = "Model: fake";
    return GP_OK;
  }
  int GetConfig(std::vector<ConfigWidget>* widgets) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("get_config", lock); code != GP_OK) return code;
    if (state_->config_result != GP_OK) return state_->config_result;
    *widgets = state_->widgets;
    if (auto it = state_->serial_by_port.find(port_);
        it != state_->serial_by_port.end()) {
      for (ConfigWidget& widget : *widgets) {
        if (widget.name == "serialnumber") widget.value = it->second;
      }
    }
    return GP_OK;
  }
  int SetConfigValue(const std::string& name,
                     const std::string& value) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("set_config", lock); code != GP_OK) return code;
    for (ConfigWidget& widget : state_->widgets) {
      if (widget.name != name) continue;
      state_->sets.emplace_back(name, value);
      if (!state_->ignored.count(name)) widget.value = value;
      return GP_OK;
    }
    return GP_ERROR_BAD_PARAMETERS;
  }
  int Capture(std::string* folder, std::string* name) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("capture", lock); code != GP_OK) return code;
    for (const ConfigWidget& widget : state_->widgets) {
      if ((widget.name == "viewfinder" || widget.name == "eosviewfinder") &&
          widget.value == "1") {
        state_->error_text = "mirror up in live view";
        return GP_ERROR;
      }
    }
    if (state_->capture_produces.empty()) return GP_ERROR;
    *folder = state_->capture_produces[0].first;
    *name = state_->capture_produces[0].second;
    for (size_t i = 1; i < state_->capture_produces.size(); ++i) {
      CameraEvent event;
      event.type = EventType::kFileAdded;
      event.folder = state_->capture_produces[i].first;
      event.name = state_->capture_produces[i].second;
      state_->events.push_back(event);
    }
    return GP_OK;
  }
  int CapturePreview(FileData* file) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("preview", lock); code != GP_OK) return code;
    for (ConfigWidget& widget : state_->widgets) {
      if (widget.name == "viewfinder" || widget.name == "eosviewfinder") {
        widget.value = "1";
      }
    }
    file->bytes = state_->preview_bytes;
    return GP_OK;
  }
  int WaitForEvent(absl::Duration /*timeout*/, CameraEvent* event) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("wait_for_event", lock); code != GP_OK) return code;
    *event = CameraEvent();  // kTimeout
    if (!state_->events.empty()) {
      *event = state_->events.front();
      state_->events.pop_front();
    }
    return GP_OK;
  }
  int ListFiles(const std::string& folder,
                std::vector<std::string>* names) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("list", lock); code != GP_OK) return code;
    names->clear();
    for (const auto& [path, bytes] : state_->files) {
      if (path.rfind(folder + "/", 0) == 0) {
        names->push_back(path.substr(folder.size() + 1));
      }
    }
    return GP_OK;
  }
  int GetFile(const std::string& folder, const std::string& name,
              FileData* file) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("get_file", lock); code != GP_OK) return code;
    auto it = state_->files.find(folder + "/" + name);
    if (it == state_->files.end()) return GP_ERROR_FILE_NOT_FOUND;
    file->bytes = it->second;
    file->mtime = absl::FromUnixSeconds(1700000000);
    return GP_OK;
  }
  int DeleteFile(const std::string& folder, const std::string& name) override {
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (int code = Enter("delete", lock); code != GP_OK) return code;
    if (state_->files.erase(folder + "/" + name) == 0) {
      return GP_ERROR_FILE_NOT_FOUND;
    }
    state_->deleted.push_back(folder + "/" + name);
    return GP_OK;
  }
  void Cancel() override {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->cancel_requested = true;
    ++state_->cancels;
    state_->cv.notify_all();
  }
  void BeginCall() override {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->cancel_requested = false;
  }
  std::string ErrorText(int code) override {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return absl::StrCat("fake error ", code,
                        state_->error_text.empty() ? "" : ": ",
                        state_->error_text);
  }

 private:
  // Counts the call; returns a scripted code, or hangs, or GP_OK to go on.
  int Enter(const std::string& op, std::unique_lock<std::mutex>& lock) {
    ++state_->calls[op];
    auto script = state_->scripted.find(op);
    if (script != state_->scripted.end() && !script->second.empty()) {
      int code = script->second.front();
      script->second.pop_front();
      return code;
    }
    if (state_->hang_op == op) {
      state_->hanging = true;
      state_->cv.notify_all();
      state_->cv.wait(lock, [&] {
        return state_->released ||
               (state_->hang_honours_cancel && state_->cancel_requested);
      });
      state_->hanging = false;
      state_->hang_op.clear();
      if (!state_->released) return GP_ERROR_CANCEL;
    }
    return GP_OK;
  }

  std::shared_ptr<FakeState> state_;
  std::string port_;  // what this api opened; "" while none
};

class Gphoto2CameraTest : public ::testing::Test {
 protected:
  Gphoto2CameraTest() : state_(std::make_shared<FakeState>()) {
    state_->widgets = CanonWidgets();
    options_.busy_backoff = absl::Milliseconds(1);
    options_.busy_backoff_max = absl::Milliseconds(4);
    options_.cancel_grace = absl::Milliseconds(50);
    options_.second_file_timeout = absl::Seconds(5);
  }

  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Open() {
    return Gphoto2Camera::OpenWithApi(options_,
                                      std::make_unique<FakeApi>(state_));
  }
  std::unique_ptr<Gphoto2Camera> OpenOrDie() {
    absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera = Open();
    EXPECT_TRUE(camera.ok()) << camera.status();
    return camera.ok() ? std::move(*camera) : nullptr;
  }
  std::string Value(const std::string& name) {
    std::lock_guard<std::mutex> lock(state_->mutex);
    for (const ConfigWidget& widget : state_->widgets) {
      if (widget.name == name) return widget.value;
    }
    return "(missing)";
  }
  void SetValue(const std::string& name, const std::string& value) {
    for (ConfigWidget& widget : state_->widgets) {
      if (widget.name == name) widget.value = value;
    }
  }
  // Polls until a hanging fake call has returned and the worker is free.
  bool WaitUntilUsable(Gphoto2Camera& camera) {
    for (int i = 0; i < 10000; ++i) {
      if (!absl::IsUnavailable(camera.Info().status())) return true;
      absl::SleepFor(absl::Milliseconds(1));
    }
    return false;
  }
  void WaitUntilHanging() {
    std::unique_lock<std::mutex> lock(state_->mutex);
    state_->cv.wait(lock, [&] { return state_->hanging; });
  }

  std::shared_ptr<FakeState> state_;
  Gphoto2Options options_;
};

TEST_F(Gphoto2CameraTest, OpensTheFirstCameraFoundAndCapturesToRam) {
  state_->detected.push_back({"Nikon DSC D800", "usb:001,005"});
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  EXPECT_EQ(camera->model(), "Canon EOS 5D Mark III");
  EXPECT_EQ(camera->port(), "usb:001,004");
  EXPECT_EQ(state_->opened_model, "Canon EOS 5D Mark III");
  EXPECT_EQ(state_->opened_port, "usb:001,004");
  EXPECT_EQ(Value("capturetarget"), "Internal RAM");
}

TEST_F(Gphoto2CameraTest, OpensByModelCaseInsensitivelyOrByPort) {
  state_->detected.push_back({"Nikon DSC D800", "usb:001,005"});
  options_.model = "nikon dsc d800";
  ASSERT_NE(OpenOrDie(), nullptr);
  EXPECT_EQ(state_->opened_model, "Nikon DSC D800");

  options_.model.clear();
  options_.port = "usb:001,005";
  ASSERT_NE(OpenOrDie(), nullptr);
  EXPECT_EQ(state_->opened_port, "usb:001,005");
}

TEST_F(Gphoto2CameraTest, ModelAndPortTogetherSkipAutodetection) {
  options_.model = "Directory Browse";
  options_.port = "disk:/tmp/folder";
  ASSERT_NE(OpenOrDie(), nullptr);
  EXPECT_EQ(state_->calls["autodetect"], 0);
  EXPECT_EQ(state_->opened_model, "Directory Browse");
  EXPECT_EQ(state_->opened_port, "disk:/tmp/folder");
}

TEST_F(Gphoto2CameraTest, NoCameraFoundSaysSo) {
  state_->detected.clear();
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera = Open();
  EXPECT_EQ(camera.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("no camera found"));
  EXPECT_EQ(state_->calls["open"], 0);
}

TEST_F(Gphoto2CameraTest, NoMatchingCameraListsThoseFound) {
  options_.model = "Sony ILCE-7M3";
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera = Open();
  EXPECT_EQ(camera.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("\"Canon EOS 5D Mark III\" on usb:001,004"));
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("Sony ILCE-7M3"));
}

// A model libgphoto2 has no driver for is a configuration that no camera
// can satisfy: NOT_FOUND, before any camera is looked for.
TEST_F(Gphoto2CameraTest, AModelLibgphoto2DoesNotKnowIsNotFoundAtOnce) {
  state_->unknown_models = {"Canon EOS 5D Mk III"};
  options_.model = "Canon EOS 5D Mk III";
  EXPECT_THAT(
      Open(),
      StatusIs(absl::StatusCode::kNotFound,
               HasSubstr("look up camera model \"Canon EOS 5D Mk III\": "
                         "libgphoto2 knows no such camera model")));
  EXPECT_EQ(state_->calls["autodetect"], 0);
  EXPECT_EQ(state_->calls["open"], 0);

  // A known model that is not connected is a camera not there (yet).
  options_.model = "Nikon DSC D800";
  EXPECT_THAT(Open(), StatusIs(absl::StatusCode::kUnavailable,
                               HasSubstr("no camera matching model \"Nikon "
                                         "DSC D800\"")));
}

TEST_F(Gphoto2CameraTest, ClaimFailureNamesTheUsualCulpritAndTheFix) {
  state_->open_result = GP_ERROR_IO_USB_CLAIM;
  state_->error_text = "Could not claim the USB device";
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera = Open();
  EXPECT_EQ(camera.status().code(), absl::StatusCode::kUnavailable);
  const std::string message(camera.status().message());
  EXPECT_THAT(message, HasSubstr("could not claim the USB device"));
  EXPECT_THAT(message, HasSubstr("gvfs-gphoto2-volume-monitor"));
  EXPECT_THAT(message, HasSubstr("pkill -f gvfs-gphoto2"));
  EXPECT_THAT(message, HasSubstr("usb:001,004"));
}

TEST_F(Gphoto2CameraTest, InfoReadsModelSerialBatteryAndRange) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::CameraInfo> info = camera->Info();
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->model, "Canon EOS 5D Mark III");
  EXPECT_EQ(info->serial, "0123456789");
  EXPECT_EQ(info->port, "usb:001,004");
  EXPECT_EQ(info->battery_percent, 75);
  EXPECT_DOUBLE_EQ(info->min_exposure_s, 1.0 / 8000);
  EXPECT_DOUBLE_EQ(info->max_exposure_s, 30);
  // The timed choices, ascending (bulb is not one): what automatic
  // bracketing chooses from.
  ASSERT_EQ(info->shutter_speeds_s.size(), 19u);
  EXPECT_DOUBLE_EQ(info->shutter_speeds_s.front(), 1.0 / 8000);
  EXPECT_DOUBLE_EQ(info->shutter_speeds_s[6], 1.0 / 125);
  EXPECT_DOUBLE_EQ(info->shutter_speeds_s.back(), 30);
}

TEST_F(Gphoto2CameraTest, CamerasWithoutConfigurationStillOpenAndInform) {
  state_->config_result = GP_ERROR_NOT_SUPPORTED;
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::CameraInfo> info = camera->Info();
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->model, "Canon EOS 5D Mark III");
  EXPECT_EQ(info->battery_percent, -1);
  EXPECT_EQ(camera->Settings().status().code(),
            absl::StatusCode::kUnimplemented);
}

TEST_F(Gphoto2CameraTest, ConfigureUsesTheNearestShutterSpeedAndReportsIt) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  hardware::ExposureSettings wanted;
  wanted.exposure_s = 1.0 / 100;
  wanted.iso = 100;
  wanted.aperture_f = 5.6;
  wanted.format = ImageFormat::kRaw;
  absl::StatusOr<hardware::ExposureSettings> used = camera->Configure(wanted);
  ASSERT_TRUE(used.ok()) << used.status();
  EXPECT_DOUBLE_EQ(used->exposure_s, 1.0 / 125);
  EXPECT_EQ(used->iso, 100);
  EXPECT_DOUBLE_EQ(used->aperture_f, 5.6);
  EXPECT_EQ(used->format, ImageFormat::kRaw);
  EXPECT_EQ(Value("shutterspeed"), "1/125");
  EXPECT_EQ(Value("iso"), "100");
  EXPECT_EQ(Value("aperture"), "5.6");
  EXPECT_EQ(Value("imageformat"), "RAW");

  absl::StatusOr<hardware::ExposureSettings> now = camera->Settings();
  ASSERT_TRUE(now.ok());
  EXPECT_DOUBLE_EQ(now->exposure_s, 1.0 / 125);
}

TEST_F(Gphoto2CameraTest, ConfigureMapsJpegAndRawPlusJpegChoices) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  hardware::ExposureSettings wanted;
  wanted.exposure_s = 2;
  wanted.format = ImageFormat::kRawAndJpeg;
  ASSERT_TRUE(camera->Configure(wanted).ok());
  EXPECT_EQ(Value("imageformat"), "RAW + Large Fine JPEG");
  wanted.format = ImageFormat::kJpeg;
  absl::StatusOr<hardware::ExposureSettings> used = camera->Configure(wanted);
  ASSERT_TRUE(used.ok());
  EXPECT_EQ(Value("imageformat"), "Large Fine JPEG");
  EXPECT_EQ(used->format, ImageFormat::kJpeg);
  EXPECT_EQ(Value("iso"), "400");  // iso 0: left as it was
}

TEST_F(Gphoto2CameraTest, UnsupportedValuesListChoicesAndChangeNothing) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->sets.clear();
  hardware::ExposureSettings wanted;
  wanted.exposure_s = 1.0 / 125;  // valid, but must not be set alone
  wanted.iso = 250;
  absl::StatusOr<hardware::ExposureSettings> used = camera->Configure(wanted);
  EXPECT_EQ(used.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(used.status().message()),
              HasSubstr("\"Auto\", \"100\", \"200\", \"400\", \"800\""));

  wanted.iso = 0;
  wanted.aperture_f = 2.8;
  EXPECT_EQ(camera->Configure(wanted).status().code(),
            absl::StatusCode::kInvalidArgument);
  wanted.aperture_f = 0;
  wanted.exposure_s = 120;  // beyond 30 s; bulb is not used
  EXPECT_EQ(camera->Configure(wanted).status().code(),
            absl::StatusCode::kInvalidArgument);
  wanted.exposure_s = 0;
  EXPECT_EQ(camera->Configure(wanted).status().code(),
            absl::StatusCode::kInvalidArgument);
  wanted.exposure_s = 1;
  wanted.format = ImageFormat::kPng8;
  EXPECT_EQ(camera->Configure(wanted).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(state_->sets, IsEmpty());
  EXPECT_EQ(Value("shutterspeed"), "1/60");

  absl::Status bad_choice = camera->SetConfigValue("iso", "250");
  EXPECT_EQ(bad_choice.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(bad_choice.message()), HasSubstr("\"800\""));
  EXPECT_EQ(camera->SetConfigValue("nosuchwidget", "1").code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(camera->SetConfigValue("iso", "800").ok());
  EXPECT_EQ(Value("iso"), "800");
}

TEST_F(Gphoto2CameraTest, ASettingTheCameraIgnoresIsAnError) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->ignored.insert("shutterspeed");  // e.g. mode dial on Av
  hardware::ExposureSettings wanted;
  wanted.exposure_s = 1.0 / 250;
  absl::StatusOr<hardware::ExposureSettings> used = camera->Configure(wanted);
  EXPECT_EQ(used.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(used.status().message()), HasSubstr("mode dial"));
  EXPECT_THAT(std::string(used.status().message()), HasSubstr("1/250"));
}

TEST_F(Gphoto2CameraTest, AReadOnlySettingIsAnErrorBeforeAnythingIsSet) {
  for (ConfigWidget& widget : state_->widgets) {
    if (widget.name == "shutterspeed") widget.read_only = true;
  }
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->sets.clear();
  hardware::ExposureSettings wanted;
  wanted.exposure_s = 1.0 / 250;
  wanted.iso = 100;
  EXPECT_EQ(camera->Configure(wanted).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(state_->sets, IsEmpty());
}

TEST_F(Gphoto2CameraTest, CaptureDownloadsAndDeletesTheFile) {
  const std::string folder = "/store_00020001/DCIM/100CANON";
  state_->capture_produces = {{folder, "IMG_0001.JPG"}};
  state_->files[folder + "/IMG_0001.JPG"] = "\xff\xd8jpeg bytes";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->bytes, "\xff\xd8jpeg bytes");
  EXPECT_EQ(frame->format, ImageFormat::kJpeg);
  EXPECT_EQ(frame->extension, "jpg");
  EXPECT_DOUBLE_EQ(frame->exposure_s, 1.0 / 60);
  EXPECT_EQ(frame->camera_time, absl::FromUnixSeconds(1700000000));
  EXPECT_THAT(state_->deleted, ElementsAre(folder + "/IMG_0001.JPG"));
  EXPECT_THAT(camera->undeleted_files(), IsEmpty());
}

TEST_F(Gphoto2CameraTest, RawPlusJpegReturnsTheRawFileAndDeletesBoth) {
  SetValue("imageformat", "RAW + Large Fine JPEG");
  state_->capture_produces = {{"/ram", "capt0000.jpg"},
                              {"/ram", "capt0001.cr2"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg";
  state_->files["/ram/capt0001.cr2"] = "raw";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->bytes, "raw");
  EXPECT_EQ(frame->format, ImageFormat::kRaw);
  EXPECT_EQ(frame->extension, "cr2");
  EXPECT_THAT(state_->deleted,
              ElementsAre("/ram/capt0000.jpg", "/ram/capt0001.cr2"));
}

TEST_F(Gphoto2CameraTest, AFailedDeleteKeepsTheFrameAndRemembersTheFile) {
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg";
  state_->scripted["delete"] = {GP_ERROR_IO};
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_THAT(camera->undeleted_files(), ElementsAre("/ram/capt0000.jpg"));
}

TEST_F(Gphoto2CameraTest, AnEmptyDownloadIsDataLoss) {
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  EXPECT_EQ(camera->Capture().status().code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(state_->deleted, IsEmpty());  // kept for another try
}

TEST_F(Gphoto2CameraTest, BusyTwiceThenOkIsRetried) {
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg";
  state_->scripted["capture"] = {GP_ERROR_CAMERA_BUSY, GP_ERROR_CAMERA_BUSY};
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(state_->calls["capture"], 3);
}

TEST_F(Gphoto2CameraTest, BusyForeverGivesUpAfterTheConfiguredRetries) {
  options_.busy_retries = 3;
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->scripted["capture"] = std::deque<int>(100, GP_ERROR_CAMERA_BUSY);
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  EXPECT_EQ(frame.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(frame.status().message()), HasSubstr("stayed busy"));
  EXPECT_THAT(std::string(frame.status().message()), HasSubstr("4 tries"));
  EXPECT_EQ(state_->calls["capture"], 4);
}

TEST_F(Gphoto2CameraTest, AnUnspecifiedCaptureErrorHintsAtFocus) {
  state_->scripted["capture"] = {GP_ERROR};
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  EXPECT_EQ(frame.status().code(), absl::StatusCode::kUnknown);
  EXPECT_THAT(std::string(frame.status().message()), HasSubstr("MF"));
  EXPECT_EQ(state_->calls["capture"], 1);
}

TEST_F(Gphoto2CameraTest, OtherErrorsAreNotRetried) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->scripted["get_config"] = {GP_ERROR_IO_READ};
  state_->calls.clear();
  absl::StatusOr<hardware::ExposureSettings> settings = camera->Settings();
  EXPECT_EQ(settings.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(state_->calls["get_config"], 1);
}

// A call that returns once asked to cancel (within the grace) leaves the
// camera usable at once: a timeout, not a stuck camera.
TEST_F(Gphoto2CameraTest, AHungCallTimesOutIsCancelledAndTheCameraRecovers) {
  options_.capture_timeout = absl::Milliseconds(200);
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->hang_op = "capture";
  state_->hang_honours_cancel = true;
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  // 200 ms plus the exposure, 1/60 s.
  EXPECT_THAT(frame, StatusIs(absl::StatusCode::kDeadlineExceeded,
                              HasSubstr("capture: no answer from the camera "
                                        "within 216.6")));
  EXPECT_THAT(std::string(frame.status().message()),
              HasSubstr("the call was cancelled"));
  EXPECT_FALSE(hardware::IsCameraStuck(frame.status()));
  EXPECT_FALSE(hardware::IsCameraGone(frame.status()));
  EXPECT_THAT(camera->Info(), IsOk());
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    EXPECT_GE(state_->cancels, 1);
    EXPECT_EQ(state_->calls["capture"], 1);  // the call ran and was cancelled
    state_->hang_op.clear();
  }
  frame = camera->Capture();
  EXPECT_TRUE(frame.ok()) << frame.status();
}

TEST_F(Gphoto2CameraTest, WhileACallIsStuckOthersFailFastUntilItReturns) {
  options_.call_timeout = absl::Milliseconds(200);
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->hang_op = "get_config";  // ignores cancellation
  absl::Status timed_out = camera->Settings().status();
  EXPECT_THAT(timed_out,
              StatusIs(absl::StatusCode::kDeadlineExceeded,
                       HasSubstr("libgphoto2 has not returned within 50ms")));
  // Stuck: the camera's connection is held; a reconnecting camera drops it.
  EXPECT_TRUE(hardware::IsCameraStuck(timed_out));
  EXPECT_TRUE(hardware::IsCameraGone(timed_out));
  absl::StatusOr<hardware::CameraInfo> info = camera->Info();
  EXPECT_THAT(info, StatusIs(absl::StatusCode::kUnavailable,
                             HasSubstr("still stuck in \"read the camera "
                                       "configuration\"")));
  EXPECT_TRUE(hardware::IsCameraStuck(info.status()));
  state_->Release();
  EXPECT_TRUE(WaitUntilUsable(*camera));
  EXPECT_TRUE(camera->Info().ok());
}

TEST_F(Gphoto2CameraTest, DestroyingACameraWithAStuckCallDoesNotWait) {
  options_.call_timeout = absl::Milliseconds(200);
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->hang_op = "get_config";
  EXPECT_EQ(camera->Settings().status().code(),
            absl::StatusCode::kDeadlineExceeded);
  WaitUntilHanging();
  const Gphoto2Camera::HandleWatch watch = camera->WatchHandle();
  camera.reset();  // returns although the fake call still hangs
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    EXPECT_TRUE(state_->hanging);
    EXPECT_FALSE(state_->api_destroyed);
  }
  // The handle is held by the stuck call, as the watch says.
  std::optional<HandleUse> use = watch();
  ASSERT_TRUE(use.has_value());
  EXPECT_EQ(use->stuck_call, "read the camera configuration");
  EXPECT_LE(use->stuck_since, absl::Now());
  state_->Release();
  // The detached worker closes the camera once the call returns.
  std::unique_lock<std::mutex> lock(state_->mutex);
  state_->cv.wait(lock, [&] { return state_->api_destroyed; });
}

TEST_F(Gphoto2CameraTest, ListsDownloadsAndDeletesFiles) {
  state_->files["/DCIM/a.JPG"] = "a";
  state_->files["/DCIM/b.NEF"] = "b";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  absl::StatusOr<std::vector<std::string>> names = camera->ListFiles("/DCIM");
  ASSERT_TRUE(names.ok());
  EXPECT_THAT(*names, ElementsAre("a.JPG", "b.NEF"));
  absl::StatusOr<hardware::Frame> raw = camera->Download("/DCIM", "b.NEF");
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->format, ImageFormat::kRaw);
  EXPECT_EQ(raw->extension, "nef");
  EXPECT_EQ(camera->Download("/DCIM", "missing.jpg").status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_TRUE(camera->DeleteFile("/DCIM", "a.JPG").ok());
  EXPECT_THAT(state_->deleted, ElementsAre("/DCIM/a.JPG"));
}

// A camera that switched its capture target and still holds a file from
// before: PrepareCaptureGroup sets RAM again and deletes the stale file, so
// the next capture is not answered with it.
TEST_F(Gphoto2CameraTest, PrepareCaptureGroupResetsTheTargetAndDrainsFiles) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    SetValue("capturetarget", "Memory card");
    state_->files["/store_00010001/DCIM/IMG_0007.JPG"] = "stale";
    CameraEvent stale;
    stale.type = EventType::kFileAdded;
    stale.folder = "/store_00010001/DCIM";
    stale.name = "IMG_0007.JPG";
    state_->events.push_back(stale);
    state_->events.push_back(CameraEvent{EventType::kCaptureComplete, "", ""});
  }
  absl::StatusOr<int> discarded = camera->PrepareCaptureGroup();
  ASSERT_TRUE(discarded.ok()) << discarded.status();
  EXPECT_EQ(*discarded, 1);
  EXPECT_EQ(Value("capturetarget"), "Internal RAM");
  EXPECT_THAT(state_->deleted,
              ElementsAre("/store_00010001/DCIM/IMG_0007.JPG"));

  // Where the file was stored, and its name, come with the frame.
  state_->capture_produces = {{"/store_00010001/DCIM", "IMG_0008.JPG"}};
  state_->files["/store_00010001/DCIM/IMG_0008.JPG"] = "\xff\xd8jpeg";
  absl::StatusOr<hardware::Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->camera_file_name, "IMG_0008.JPG");
  EXPECT_EQ(frame->stored_to, hardware::StoredTo::kCard);
}

TEST(Gphoto2ErrorTest, MapsResultCodesToStatusCodes) {
  struct Case {
    int code;
    absl::StatusCode status;
  };
  for (const Case& c : std::vector<Case>{
           {GP_ERROR_IO_USB_CLAIM, absl::StatusCode::kUnavailable},
           {GP_ERROR_IO_USB_FIND, absl::StatusCode::kUnavailable},
           {GP_ERROR_IO, absl::StatusCode::kUnavailable},
           {GP_ERROR_CAMERA_BUSY, absl::StatusCode::kUnavailable},
           {GP_ERROR_TIMEOUT, absl::StatusCode::kDeadlineExceeded},
           {GP_ERROR_NOT_SUPPORTED, absl::StatusCode::kUnimplemented},
           {GP_ERROR_BAD_PARAMETERS, absl::StatusCode::kInvalidArgument},
           {GP_ERROR_CORRUPTED_DATA, absl::StatusCode::kDataLoss},
           {GP_ERROR_MODEL_NOT_FOUND, absl::StatusCode::kNotFound},
           {GP_ERROR_UNKNOWN_PORT, absl::StatusCode::kNotFound},
           {GP_ERROR_FILE_NOT_FOUND, absl::StatusCode::kNotFound},
           {GP_ERROR_NO_SPACE, absl::StatusCode::kResourceExhausted},
           {GP_ERROR_IO_READ, absl::StatusCode::kUnavailable},
           {GP_ERROR, absl::StatusCode::kUnknown},
           {GP_ERROR_CAMERA_ERROR, absl::StatusCode::kUnknown},
       }) {
    absl::Status status = Gphoto2Error("do it", c.code, "detail");
    EXPECT_EQ(status.code(), c.status) << c.code;
    EXPECT_THAT(std::string(status.message()), HasSubstr("do it"));
    EXPECT_THAT(std::string(status.message()),
                HasSubstr(absl::StrCat("[", c.code, "]")));
  }
}

TEST_F(Gphoto2CameraTest, PreviewReturnsTheCamerasLiveViewJpeg) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  ASSERT_OK_AND_ASSIGN(hardware::Frame frame, camera->Preview());
  EXPECT_EQ(frame.bytes, "\xff\xd8 live view");
  EXPECT_EQ(frame.format, ImageFormat::kJpeg);
  EXPECT_EQ(frame.extension, "jpg");
  EXPECT_DOUBLE_EQ(frame.exposure_s, 1.0 / 60);  // the camera's setting
  EXPECT_EQ(state_->calls["preview"], 1);
  EXPECT_EQ(state_->calls["capture"], 0);  // nothing stored on the camera
}

// libgphoto2#66: the second preview is answered "PTP Device Busy" while
// the camera is still starting live view; it is retried with backoff.
TEST_F(Gphoto2CameraTest, ASecondPreviewAnsweredBusyIsRetried) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  ASSERT_OK(camera->Preview().status());
  state_->scripted["preview"] = {GP_ERROR_CAMERA_BUSY, GP_ERROR_CAMERA_BUSY};
  ASSERT_OK_AND_ASSIGN(hardware::Frame frame, camera->Preview());
  EXPECT_EQ(frame.bytes, "\xff\xd8 live view");
  EXPECT_EQ(state_->calls["preview"], 4);

  // Busy beyond the retries: UNAVAILABLE, saying how long it tried.
  state_->scripted["preview"] = std::deque<int>(6, GP_ERROR_CAMERA_BUSY);
  EXPECT_THAT(camera->Preview(),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("capture a live-view frame: the camera "
                                 "stayed busy")));
  EXPECT_EQ(state_->calls["preview"], 10);
}

// libgphoto2#247 and friends: after live view the mirror stays up and a
// capture fails; the driver sets the viewfinder toggle to 0 first, once.
TEST_F(Gphoto2CameraTest, ACaptureAfterPreviewLeavesLiveViewFirst) {
  state_->widgets.push_back(Toggle("viewfinder", "0"));
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  // Without a preview nothing is released.
  state_->files["/ram/capt0000.jpg"] = "first";
  ASSERT_OK(camera->Capture().status());
  EXPECT_THAT(state_->sets, ::testing::Not(::testing::Contains(std::make_pair(
                                std::string("viewfinder"), std::string("0")))));

  ASSERT_OK(camera->Preview().status());
  EXPECT_EQ(Value("viewfinder"), "1");
  state_->sets.clear();
  state_->files["/ram/capt0000.jpg"] = "second";
  ASSERT_OK_AND_ASSIGN(hardware::Frame frame, camera->Capture());
  EXPECT_EQ(frame.bytes, "second");
  EXPECT_EQ(Value("viewfinder"), "0");
  EXPECT_THAT(state_->sets, ElementsAre(std::make_pair(
                                std::string("viewfinder"), std::string("0"))));

  // Out of live view: the next capture sets nothing.
  state_->sets.clear();
  state_->files["/ram/capt0000.jpg"] = "third";
  ASSERT_OK(camera->Capture().status());
  EXPECT_THAT(state_->sets, IsEmpty());
}

TEST_F(Gphoto2CameraTest, OlderCanonBodiesLeaveLiveViewByEosviewfinder) {
  state_->widgets.push_back(Toggle("eosviewfinder", "0"));
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  ASSERT_OK(camera->Preview().status());
  ASSERT_OK(camera->Capture().status());
  EXPECT_EQ(Value("eosviewfinder"), "0");
}

TEST_F(Gphoto2CameraTest, ACaptureThatCannotLeaveLiveViewFailsBeforeFiring) {
  state_->widgets.push_back(Toggle("viewfinder", "0"));
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg";
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  ASSERT_OK(camera->Preview().status());
  state_->scripted["set_config"] = {GP_ERROR_NOT_SUPPORTED};
  EXPECT_THAT(camera->Capture(),
              StatusIs(absl::StatusCode::kUnimplemented,
                       HasSubstr("leaving live view before the capture (the "
                                 "mirror would stay up): set viewfinder")));
  EXPECT_EQ(state_->calls["capture"], 0);
  // The next capture tries again, and succeeds.
  ASSERT_OK(camera->Capture().status());
  EXPECT_EQ(Value("viewfinder"), "0");
}

TEST_F(Gphoto2CameraTest, APreviewThatIsNoJpegOrNotSupportedSaysSo) {
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->preview_bytes = "PNG?";
  EXPECT_THAT(camera->Preview(),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("live-view frame is not a JPEG (4 bytes)")));
  state_->scripted["preview"] = {GP_ERROR_NOT_SUPPORTED};
  EXPECT_THAT(camera->Preview(),
              StatusIs(absl::StatusCode::kUnimplemented,
                       HasSubstr("capture a live-view frame: not supported")));
}

TEST_F(Gphoto2CameraTest, AHungPreviewTimesOut) {
  options_.preview_timeout = absl::Milliseconds(200);
  std::unique_ptr<Gphoto2Camera> camera = OpenOrDie();
  ASSERT_NE(camera, nullptr);
  state_->hang_op = "preview";
  state_->hang_honours_cancel = true;
  EXPECT_THAT(camera->Preview(),
              StatusIs(absl::StatusCode::kDeadlineExceeded,
                       HasSubstr("capture a live-view frame: no answer from "
                                 "the camera within 200ms")));
  EXPECT_TRUE(WaitUntilUsable(*camera));
  ASSERT_OK(camera->Preview().status());
}

// A ReconnectingCamera passes live view through.
TEST_F(Gphoto2CameraTest, PreviewGoesThroughTheReconnectingCamera) {
  std::unique_ptr<Gphoto2Camera> opened = OpenOrDie();
  ASSERT_NE(opened, nullptr);
  hardware::ReconnectingCamera camera(
      std::move(opened),
      []() -> absl::StatusOr<std::unique_ptr<hardware::Camera>> {
        return absl::UnavailableError("not reopened in this test");
      });
  ASSERT_OK_AND_ASSIGN(hardware::Frame frame, camera.Preview());
  EXPECT_EQ(frame.bytes, "\xff\xd8 live view");
}

// After a USB reset the camera is back on another port, perhaps beside
// another body of the same model: Reopen finds it by its serial number.
TEST_F(Gphoto2CameraTest, ReopenFindsTheCameraBySerialOnItsNewPort) {
  state_->detected = {{"Canon EOS 5D Mark III", "usb:001,009"},
                      {"Nikon DSC D800", "usb:001,010"},
                      {"Canon EOS 5D Mark III", "usb:001,012"}};
  state_->serial_by_port = {{"usb:001,009", "1111111111"},
                            {"usb:001,010", "0123456789"},
                            {"usb:001,012", "0123456789"}};
  options_.model = "Canon EOS 5D Mark III";
  options_.port = "usb:001,004";  // where it was: ignored
  int apis = 0;
  Gphoto2Camera::ApiFactory new_api = [&] {
    ++apis;
    return std::make_unique<FakeApi>(state_);
  };
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      Gphoto2Camera::Reopen(options_, "0123456789", new_api);
  ASSERT_TRUE(camera.ok()) << camera.status();
  EXPECT_EQ((*camera)->port(), "usb:001,012");
  absl::StatusOr<hardware::CameraInfo> info = (*camera)->Info();
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->serial, "0123456789");
  // One api to autodetect, one per Canon opened; the Nikon is not opened.
  EXPECT_EQ(apis, 3);
  // The reopened camera works as any opened one.
  EXPECT_EQ(Value("capturetarget"), "Internal RAM");
}

TEST_F(Gphoto2CameraTest, ReopenWithoutTheSerialsCameraNamesWhatItFound) {
  state_->detected = {{"Canon EOS 5D Mark III", "usb:001,009"}};
  state_->serial_by_port = {{"usb:001,009", "1111111111"}};
  Gphoto2Camera::ApiFactory new_api = [&] {
    return std::make_unique<FakeApi>(state_);
  };
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      Gphoto2Camera::Reopen(options_, "0123456789", new_api);
  EXPECT_TRUE(absl::IsUnavailable(camera.status())) << camera.status();
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("no camera with serial number \"0123456789\"; "
                        "found: \"Canon EOS 5D Mark III\" on usb:001,009 "
                        "(serial number \"1111111111\")"));

  state_->detected.clear();  // still re-enumerating
  camera = Gphoto2Camera::Reopen(options_, "0123456789", new_api);
  EXPECT_TRUE(absl::IsUnavailable(camera.status())) << camera.status();
  EXPECT_THAT(std::string(camera.status().message()), HasSubstr("found: none"));

  // A camera without a serial number is reopened by model.
  state_->detected = {{"Nikon DSC D800", "usb:001,010"},
                      {"Canon EOS 5D Mark III", "usb:001,011"}};
  options_.model = "Canon EOS 5D Mark III";
  camera = Gphoto2Camera::Reopen(options_, "", new_api);
  ASSERT_TRUE(camera.ok()) << camera.status();
  EXPECT_EQ((*camera)->port(), "usb:001,011");
}

// The whole path: a capture that fails with an I/O error (the cable) drops
// the camera; ReconnectingCamera reopens it by serial, after the camera
// was absent for two attempts, and captures go on from the new port.
TEST_F(Gphoto2CameraTest, AnIoErrorDropsTheCameraAndItIsReopenedBySerial) {
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg bytes";
  std::unique_ptr<Gphoto2Camera> opened = OpenOrDie();
  ASSERT_NE(opened, nullptr);
  const std::string serial = opened->Info()->serial;
  ASSERT_EQ(serial, "0123456789");
  Gphoto2Options reopen_options = options_;
  reopen_options.model = opened->model();
  int detections = 0;
  hardware::CameraOpener reopen =
      [&]() -> absl::StatusOr<std::unique_ptr<hardware::Camera>> {
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      // Absent for two autodetects, then on a new port.
      state_->detected.clear();
      if (++detections > 2) {
        state_->detected = {{"Canon EOS 5D Mark III", "usb:001,023"}};
      }
    }
    absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
        Gphoto2Camera::Reopen(reopen_options, serial, [this] {
          return std::make_unique<FakeApi>(state_);
        });
    if (!camera.ok()) return camera.status();
    return std::unique_ptr<hardware::Camera>(std::move(*camera));
  };
  hardware::ReconnectOptions backoff;
  backoff.initial_backoff = absl::Milliseconds(1);
  backoff.max_backoff = absl::Milliseconds(4);
  hardware::ReconnectingCamera camera(std::move(opened), reopen, backoff);

  state_->scripted["capture"] = {GP_ERROR_IO_USB_FIND};
  absl::Status dropped = camera.Capture().status();
  EXPECT_TRUE(absl::IsUnavailable(dropped)) << dropped;
  EXPECT_THAT(std::string(dropped.message()),
              HasSubstr("not on the USB bus (disconnected"));
  EXPECT_TRUE(hardware::IsCameraGone(dropped));
  EXPECT_FALSE(camera.Connection().connected);
  EXPECT_EQ(camera.Connection().drops, 1);
  bool back = false;
  for (int i = 0; i < 2000 && !back; ++i) {
    back = camera.Connection().connected;
    if (!back) absl::SleepFor(absl::Milliseconds(5));
  }
  ASSERT_TRUE(back) << hardware::DescribeConnection(camera.Connection());
  EXPECT_EQ(detections, 3);
  EXPECT_EQ(state_->opened_port, "usb:001,023");
  state_->files["/ram/capt0000.jpg"] = "jpeg bytes";
  absl::StatusOr<hardware::Frame> frame = camera.Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->bytes, "jpeg bytes");
  EXPECT_EQ(camera.Connection().drops, 1);
}

// The states a ReconnectingCamera reported (ReconnectOptions::on_change),
// so that a test waits for one instead of polling.
class ConnectionLog {
 public:
  std::function<void(const hardware::ConnectionState&)> Callback() {
    return [this](const hardware::ConnectionState& state) {
      std::lock_guard<std::mutex> lock(mutex_);
      states_.push_back(state);
      cv_.notify_all();
    };
  }
  // The first reported state that `done` accepts, waited for at most 10 s.
  std::optional<hardware::ConnectionState> WaitFor(
      const std::function<bool(const hardware::ConnectionState&)>& done) {
    std::unique_lock<std::mutex> lock(mutex_);
    std::optional<hardware::ConnectionState> found;
    cv_.wait_for(lock, std::chrono::seconds(10), [&] {
      auto it = std::find_if(states_.begin(), states_.end(), done);
      if (it != states_.end()) found = *it;
      return found.has_value();
    });
    return found;
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<hardware::ConnectionState> states_;
};

bool Connected(const hardware::ConnectionState& state) {
  return state.connected;
}

class Gphoto2OpenerTest : public Gphoto2CameraTest {
 protected:
  // ReconnectingCamera's opener: a Gphoto2Opener over fake apis.
  hardware::CameraOpener Opener() {
    return CameraOpenerOf(std::make_shared<Gphoto2Opener>(
        options_,
        [state = state_] { return std::make_unique<FakeApi>(state); }));
  }
  hardware::ReconnectOptions Backoff() {
    hardware::ReconnectOptions backoff;
    backoff.initial_backoff = absl::Milliseconds(5);
    backoff.max_backoff = absl::Milliseconds(20);
    backoff.on_change = log_.Callback();
    return backoff;
  }

  ConnectionLog log_;  // outlives the cameras of a test
};

// Not there when the daemon starts: the camera is looked for as configured
// (here: on its port) until it is there, as one that dropped would be.
TEST_F(Gphoto2OpenerTest, ACameraAbsentAtTheStartIsOpenedAsConfigured) {
  state_->detected.clear();
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg bytes";
  options_.port = "usb:001,007";
  hardware::CameraOpener open = Opener();
  absl::StatusOr<std::unique_ptr<hardware::Camera>> first = open();
  EXPECT_THAT(first, StatusIs(absl::StatusCode::kUnavailable,
                              HasSubstr("no camera found")));
  hardware::ReconnectingCamera camera(std::move(first), open, Backoff());
  hardware::ConnectionState state = camera.Connection();
  EXPECT_FALSE(state.connected);
  EXPECT_EQ(state.attempt, 1);
  EXPECT_EQ(state.drops, 0);
  EXPECT_THAT(hardware::DescribeConnection(state),
              HasSubstr("reconnecting (attempt 1): no camera found"));
  EXPECT_THAT(camera.Capture(),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("camera disconnected; reconnecting")));
  ASSERT_TRUE(log_.WaitFor(
      [](const hardware::ConnectionState& s) { return s.attempt >= 3; }));

  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->detected = {{"Nikon DSC D800", "usb:001,006"},
                        {"Canon EOS 5D Mark III", "usb:001,007"}};
  }
  ASSERT_TRUE(log_.WaitFor(Connected))
      << hardware::DescribeConnection(camera.Connection());
  EXPECT_EQ(state_->opened_port, "usb:001,007");
  EXPECT_EQ(camera.Connection().drops, 0);
  EXPECT_THAT(camera.Capture(), IsOk());
}

// A call stuck in libgphoto2 drops the camera; no second handle is opened
// on it until the stuck call returns and its handle is closed, then the
// camera is reopened by its serial number.
TEST_F(Gphoto2OpenerTest, AStuckCallDropsTheCameraReopenedOnceItReturns) {
  options_.capture_timeout = absl::Milliseconds(100);
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  state_->files["/ram/capt0000.jpg"] = "jpeg bytes";
  hardware::CameraOpener open = Opener();
  hardware::ReconnectingCamera camera(open(), open, Backoff());
  ASSERT_TRUE(camera.Connection().connected);

  state_->hang_op = "capture";  // ignores cancellation
  absl::Status stuck = camera.Capture().status();
  EXPECT_THAT(stuck, StatusIs(absl::StatusCode::kDeadlineExceeded,
                              HasSubstr("libgphoto2 has not returned")));
  EXPECT_TRUE(hardware::IsCameraStuck(stuck));
  EXPECT_FALSE(camera.Connection().connected);
  EXPECT_EQ(camera.Connection().drops, 1);

  std::optional<hardware::ConnectionState> waiting = log_.WaitFor(
      [](const hardware::ConnectionState& s) { return s.attempt >= 3; });
  ASSERT_TRUE(waiting.has_value());
  EXPECT_THAT(std::string(waiting->last_error.message()),
              HasSubstr("the camera's previous connection is still stuck in "
                        "\"capture\", which timed out "));
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    EXPECT_TRUE(state_->hanging);
    EXPECT_EQ(state_->calls["autodetect"], 1) << "no reopen while stuck";
    EXPECT_EQ(state_->open_handles, 1);
  }

  state_->Release();
  ASSERT_TRUE(log_.WaitFor(Connected))
      << hardware::DescribeConnection(camera.Connection());
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    EXPECT_EQ(state_->max_open_handles, 1) << "never two handles at once";
    EXPECT_EQ(state_->open_handles, 1);
  }
  absl::StatusOr<hardware::Frame> frame = camera.Capture();
  ASSERT_THAT(frame, IsOk());
  EXPECT_EQ(frame->bytes, "jpeg bytes");
  EXPECT_EQ(camera.Connection().drops, 1);
}

// libgphoto2 may never return: after stuck_handle_wait the old handle is
// abandoned to its thread and the camera is reopened beside it.
TEST_F(Gphoto2OpenerTest, AHandleThatIsNeverLetGoOfIsAbandonedAfterTheWait) {
  options_.capture_timeout = absl::Milliseconds(100);
  options_.stuck_handle_wait = absl::Milliseconds(300);
  state_->capture_produces = {{"/ram", "capt0000.jpg"}};
  hardware::CameraOpener open = Opener();
  hardware::ReconnectingCamera camera(open(), open, Backoff());

  state_->hang_op = "capture";
  EXPECT_TRUE(hardware::IsCameraStuck(camera.Capture().status()));
  const absl::Time dropped = absl::Now();
  ASSERT_TRUE(log_.WaitFor(Connected))
      << hardware::DescribeConnection(camera.Connection());
  EXPECT_GE(absl::Now() - dropped, absl::Milliseconds(300));
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    EXPECT_TRUE(state_->hanging) << "the old call still runs";
    EXPECT_EQ(state_->open_handles, 2);
  }
  absl::StatusOr<hardware::CameraInfo> info = camera.Info();
  ASSERT_THAT(info, IsOk());
  EXPECT_EQ(info->serial, "0123456789");

  // When it returns at last, the abandoned handle is closed.
  state_->Release();
  std::unique_lock<std::mutex> lock(state_->mutex);
  EXPECT_TRUE(state_->cv.wait_for(lock, std::chrono::seconds(10),
                                  [&] { return state_->open_handles == 1; }));
}

}  // namespace
}  // namespace hdrstereo::gphoto2
