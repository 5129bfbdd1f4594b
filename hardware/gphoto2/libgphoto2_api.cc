// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/libgphoto2_api.h"

#include <fcntl.h>
#include <gphoto2/gphoto2.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <mutex>
#include <optional>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace hdrstereo::gphoto2 {
namespace {

// Loading the camera and port drivers goes through libltdl, which is not
// thread-safe; one load at a time in this process.
std::mutex& LoadMutex() {
  static std::mutex* mutex = new std::mutex;
  return *mutex;
}

std::string OrEmpty(const char* text) { return text != nullptr ? text : ""; }

// libgphoto2 2.5.30 closes file descriptor 0 each time it closes a PTP/IP
// connection (strace: close(command socket), close(event socket),
// close(0): a third socket it keeps for Fuji cameras starts as 0, not -1).
// Around those calls descriptor 0 is kept on /dev/null, so that the close
// hits nothing of this process's. Opens elsewhere in the process can still
// take 0 between libgphoto2's close and the reopen here (the rest of
// gp_camera_exit and gp_camera_unref): camera opens cannot (the same lock),
// the simulated PTP/IP camera moves its sockets above 2, and hdrstereod
// keeps 0 open from its start; anything else that took 0 then would be
// closed at the next PTP/IP disconnect.
void KeepDescriptorZeroOnDevNull() {
  if (fcntl(0, F_GETFD) != -1) return;
  const int fd = open("/dev/null", O_RDWR);
  if (fd > 0) close(fd);  // 0 was taken in the meantime
}

// Closes `camera` (as far as it was opened) with the above around it.
void CloseCamera(Camera* camera, GPContext* context, bool initialized,
                 bool network) {
  // Under the lock camera opens hold too: no libgphoto2 open takes 0 while
  // it is free, and two closes do not undo each other's /dev/null.
  std::optional<std::lock_guard<std::mutex>> lock;
  if (network) lock.emplace(LoadMutex());
  if (network) KeepDescriptorZeroOnDevNull();
  if (initialized) gp_camera_exit(camera, context);
  gp_camera_unref(camera);
  if (network) KeepDescriptorZeroOnDevNull();
}

class Libgphoto2Api final : public Gphoto2Api {
 public:
  Libgphoto2Api() : context_(gp_context_new()) {
    gp_context_set_error_func(context_, &Libgphoto2Api::OnError, this);
    gp_context_set_cancel_func(context_, &Libgphoto2Api::OnCancel, this);
  }

  ~Libgphoto2Api() override {
    if (camera_ != nullptr) {
      CloseCamera(camera_, context_, /*initialized=*/true, network_);
    }
    if (abilities_ != nullptr) gp_abilities_list_free(abilities_);
    if (ports_ != nullptr) gp_port_info_list_free(ports_);
    gp_context_unref(context_);
  }

  int Autodetect(std::vector<DetectedCamera>* cameras) override {
    CameraList* list = nullptr;
    int result = gp_list_new(&list);
    if (result < GP_OK) return result;
    {
      std::lock_guard<std::mutex> lock(LoadMutex());
      result = gp_camera_autodetect(list, context_);
    }
    if (result >= GP_OK) {
      cameras->clear();
      for (int i = 0; i < gp_list_count(list); ++i) {
        const char* name = nullptr;
        const char* value = nullptr;
        gp_list_get_name(list, i, &name);
        gp_list_get_value(list, i, &value);
        cameras->push_back({OrEmpty(name), OrEmpty(value)});
      }
      result = GP_OK;
    }
    gp_list_free(list);
    return result;
  }

  int CheckModel(const std::string& model) override {
    if (int result = LoadLists(); result < GP_OK) return result;
    return gp_abilities_list_lookup_model(abilities_, model.c_str()) < GP_OK
               ? GP_ERROR_MODEL_NOT_FOUND
               : GP_OK;
  }

  int Open(const std::string& model, const std::string& port) override {
    if (camera_ != nullptr) return GP_ERROR_BAD_PARAMETERS;
    int result = LoadLists();
    if (result < GP_OK) return result;
    Camera* camera = nullptr;
    if ((result = gp_camera_new(&camera)) < GP_OK) return result;
    if (!model.empty()) {
      int index = gp_abilities_list_lookup_model(abilities_, model.c_str());
      if (index < GP_OK) {
        gp_camera_unref(camera);
        return GP_ERROR_MODEL_NOT_FOUND;
      }
      CameraAbilities abilities;
      gp_abilities_list_get_abilities(abilities_, index, &abilities);
      gp_camera_set_abilities(camera, abilities);
    }
    network_ = port.rfind("ptpip:", 0) == 0;
    if (network_) {
      KeepDescriptorZeroOnDevNull();
      // libgphoto2 (ptp2.so) writes to its PTP/IP sockets with write(2): a
      // camera that closed the connection must not kill the process.
      static std::once_flag ignore_sigpipe;
      std::call_once(ignore_sigpipe, [] { signal(SIGPIPE, SIG_IGN); });
    }
    if (!port.empty()) {
      // Exact paths, and patterns such as "^disk:" that accept any folder.
      int index = gp_port_info_list_lookup_path(ports_, port.c_str());
      if (index < GP_OK) {
        gp_camera_unref(camera);
        return index;
      }
      GPPortInfo info;
      gp_port_info_list_get_info(ports_, index, &info);
      gp_camera_set_port_info(camera, info);
    }
    {
      // gp_camera_init loads the camera driver (libltdl) too.
      std::lock_guard<std::mutex> lock(LoadMutex());
      result = gp_camera_init(camera, context_);
    }
    if (result < GP_OK) {
      CloseCamera(camera, context_, /*initialized=*/false, network_);
      return result;
    }
    camera_ = camera;
    return GP_OK;
  }

  int GetSummary(std::string* text) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    CameraText summary;
    int result = gp_camera_get_summary(camera_, &summary, context_);
    if (result >= GP_OK) *text = summary.text;
    return result;
  }

  int GetConfig(std::vector<ConfigWidget>* widgets) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    CameraWidget* root = nullptr;
    int result = gp_camera_get_config(camera_, &root, context_);
    if (result < GP_OK) return result;
    widgets->clear();
    Flatten(root, "", widgets);
    gp_widget_free(root);
    return GP_OK;
  }

  int SetConfigValue(const std::string& name,
                     const std::string& value) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    CameraWidget* widget = nullptr;
    int result =
        gp_camera_get_single_config(camera_, name.c_str(), &widget, context_);
    if (result < GP_OK) return result;
    CameraWidgetType type;
    gp_widget_get_type(widget, &type);
    switch (type) {
      case GP_WIDGET_TEXT:
      case GP_WIDGET_RADIO:
      case GP_WIDGET_MENU:
        result = gp_widget_set_value(widget, value.c_str());
        break;
      case GP_WIDGET_RANGE: {
        float number = 0;
        result = absl::SimpleAtof(value, &number)
                     ? gp_widget_set_value(widget, &number)
                     : GP_ERROR_BAD_PARAMETERS;
        break;
      }
      case GP_WIDGET_TOGGLE:
      case GP_WIDGET_DATE: {
        int number = 0;
        result = absl::SimpleAtoi(value, &number)
                     ? gp_widget_set_value(widget, &number)
                     : GP_ERROR_BAD_PARAMETERS;
        break;
      }
      default:
        result = GP_ERROR_NOT_SUPPORTED;
    }
    if (result >= GP_OK) {
      result =
          gp_camera_set_single_config(camera_, name.c_str(), widget, context_);
    }
    gp_widget_free(widget);
    return result;
  }

  int Capture(std::string* folder, std::string* name) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    CameraFilePath path = {};
    int result = gp_camera_capture(camera_, GP_CAPTURE_IMAGE, &path, context_);
    if (result >= GP_OK) {
      *folder = path.folder;
      *name = path.name;
    }
    return result;
  }

  int CapturePreview(FileData* file) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    ::CameraFile* gp_file = nullptr;
    int result = gp_file_new(&gp_file);
    if (result < GP_OK) return result;
    result = gp_camera_capture_preview(camera_, gp_file, context_);
    if (result >= GP_OK) result = CopyData(gp_file, file);
    gp_file_unref(gp_file);
    return result;
  }

  int WaitForEvent(absl::Duration timeout, CameraEvent* event) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    CameraEventType type = GP_EVENT_UNKNOWN;
    void* data = nullptr;
    int result = gp_camera_wait_for_event(
        camera_, static_cast<int>(absl::ToInt64Milliseconds(timeout)), &type,
        &data, context_);
    if (result < GP_OK) return result;
    *event = CameraEvent();
    switch (type) {
      case GP_EVENT_TIMEOUT:
        event->type = EventType::kTimeout;
        break;
      case GP_EVENT_FILE_ADDED: {
        event->type = EventType::kFileAdded;
        const auto* path = static_cast<const CameraFilePath*>(data);
        if (path != nullptr) {
          event->folder = path->folder;
          event->name = path->name;
        }
        break;
      }
      case GP_EVENT_CAPTURE_COMPLETE:
        event->type = EventType::kCaptureComplete;
        break;
      default:
        event->type = EventType::kOther;
    }
    free(data);  // malloc'd by the camlib (a path or a message)
    return GP_OK;
  }

  int ListFiles(const std::string& folder,
                std::vector<std::string>* names) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    CameraList* list = nullptr;
    int result = gp_list_new(&list);
    if (result < GP_OK) return result;
    result =
        gp_camera_folder_list_files(camera_, folder.c_str(), list, context_);
    if (result >= GP_OK) {
      names->clear();
      for (int i = 0; i < gp_list_count(list); ++i) {
        const char* name = nullptr;
        gp_list_get_name(list, i, &name);
        names->push_back(OrEmpty(name));
      }
    }
    gp_list_free(list);
    return result;
  }

  int GetFile(const std::string& folder, const std::string& name,
              FileData* file) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    ::CameraFile* gp_file = nullptr;
    int result = gp_file_new(&gp_file);
    if (result < GP_OK) return result;
    result = gp_camera_file_get(camera_, folder.c_str(), name.c_str(),
                                GP_FILE_TYPE_NORMAL, gp_file, context_);
    if (result >= GP_OK) result = CopyData(gp_file, file);
    gp_file_unref(gp_file);
    return result;
  }

  int DeleteFile(const std::string& folder, const std::string& name) override {
    if (camera_ == nullptr) return GP_ERROR_BAD_PARAMETERS;
    return gp_camera_file_delete(camera_, folder.c_str(), name.c_str(),
                                 context_);
  }

  void Cancel() override { cancel_.store(true); }

  void BeginCall() override {
    cancel_.store(false);
    last_error_.clear();
  }

  std::string ErrorText(int code) override {
    std::string text = gp_result_as_string(code);
    if (!last_error_.empty() && last_error_ != text) {
      absl::StrAppend(&text, " (", last_error_, ")");
    }
    return text;
  }

 private:
  // The bytes and time of a file libgphoto2 filled.
  static int CopyData(::CameraFile* gp_file, FileData* file) {
    const char* data = nullptr;
    unsigned long size = 0;
    const int result = gp_file_get_data_and_size(gp_file, &data, &size);
    if (result < GP_OK) return result;
    file->bytes.assign(data != nullptr ? data : "", data != nullptr ? size : 0);
    time_t mtime = 0;
    file->mtime = gp_file_get_mtime(gp_file, &mtime) >= GP_OK && mtime > 0
                      ? absl::FromTimeT(mtime)
                      : absl::InfinitePast();
    return GP_OK;
  }

  static void OnError(GPContext* /*context*/, const char* text, void* data) {
    auto* self = static_cast<Libgphoto2Api*>(data);
    if (text == nullptr) return;
    if (!self->last_error_.empty()) self->last_error_ += "; ";
    self->last_error_ += text;
  }

  // Loads the camera drivers' abilities and the port drivers' ports, once.
  int LoadLists() {
    std::lock_guard<std::mutex> lock(LoadMutex());
    int result = GP_OK;
    if (abilities_ == nullptr) {
      if ((result = gp_abilities_list_new(&abilities_)) < GP_OK) return result;
      if ((result = gp_abilities_list_load(abilities_, context_)) < GP_OK) {
        return result;
      }
    }
    if (ports_ == nullptr) {
      if ((result = gp_port_info_list_new(&ports_)) < GP_OK) return result;
      if ((result = gp_port_info_list_load(ports_)) < GP_OK) return result;
    }
    return GP_OK;
  }

  static GPContextFeedback OnCancel(GPContext* /*context*/, void* data) {
    return static_cast<Libgphoto2Api*>(data)->cancel_.load()
               ? GP_CONTEXT_FEEDBACK_CANCEL
               : GP_CONTEXT_FEEDBACK_OK;
  }

  static void Flatten(CameraWidget* widget, const std::string& parent,
                      std::vector<ConfigWidget>* out) {
    const char* name = nullptr;
    gp_widget_get_name(widget, &name);
    std::string path = absl::StrCat(parent, "/", OrEmpty(name));
    CameraWidgetType type;
    gp_widget_get_type(widget, &type);
    if (type == GP_WIDGET_WINDOW || type == GP_WIDGET_SECTION) {
      for (int i = 0; i < gp_widget_count_children(widget); ++i) {
        CameraWidget* child = nullptr;
        if (gp_widget_get_child(widget, i, &child) >= GP_OK) {
          Flatten(child, path, out);
        }
      }
      return;
    }
    ConfigWidget leaf;
    leaf.name = OrEmpty(name);
    leaf.path = path;
    const char* label = nullptr;
    gp_widget_get_label(widget, &label);
    leaf.label = OrEmpty(label);
    int read_only = 0;
    gp_widget_get_readonly(widget, &read_only);
    leaf.read_only = read_only != 0;
    switch (type) {
      case GP_WIDGET_TEXT:
      case GP_WIDGET_RADIO:
      case GP_WIDGET_MENU: {
        leaf.type = type == GP_WIDGET_TEXT    ? WidgetType::kText
                    : type == GP_WIDGET_RADIO ? WidgetType::kRadio
                                              : WidgetType::kMenu;
        const char* value = nullptr;
        if (gp_widget_get_value(widget, &value) >= GP_OK) {
          leaf.value = OrEmpty(value);
        }
        for (int i = 0; i < gp_widget_count_choices(widget); ++i) {
          const char* choice = nullptr;
          if (gp_widget_get_choice(widget, i, &choice) >= GP_OK) {
            leaf.choices.push_back(OrEmpty(choice));
          }
        }
        break;
      }
      case GP_WIDGET_RANGE: {
        leaf.type = WidgetType::kRange;
        float value = 0;
        if (gp_widget_get_value(widget, &value) >= GP_OK) {
          leaf.value = absl::StrFormat("%g", value);
        }
        gp_widget_get_range(widget, &leaf.min, &leaf.max, &leaf.step);
        break;
      }
      case GP_WIDGET_TOGGLE:
      case GP_WIDGET_DATE: {
        leaf.type =
            type == GP_WIDGET_TOGGLE ? WidgetType::kToggle : WidgetType::kDate;
        int value = 0;
        if (gp_widget_get_value(widget, &value) >= GP_OK) {
          leaf.value = absl::StrCat(value);
        }
        break;
      }
      default:
        leaf.type = WidgetType::kButton;
    }
    out->push_back(std::move(leaf));
  }

  GPContext* context_;
  Camera* camera_ = nullptr;
  bool network_ = false;  // a PTP/IP port (KeepDescriptorZeroOnDevNull)
  CameraAbilitiesList* abilities_ = nullptr;
  GPPortInfoList* ports_ = nullptr;
  std::atomic<bool> cancel_{false};
  std::string last_error_;
};

}  // namespace

std::unique_ptr<Gphoto2Api> NewLibgphoto2Api() {
  return std::make_unique<Libgphoto2Api>();
}

}  // namespace hdrstereo::gphoto2
