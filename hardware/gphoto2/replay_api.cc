// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/replay_api.h"

#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "hardware/gphoto2/settings.h"
#include "hardware/gphoto2/widgets.h"

namespace hdrstereo::gphoto2 {

ReplayLink::ReplayLink(std::function<absl::Status()> plug_in)
    : plug_in_(std::move(plug_in)) {}

absl::StatusOr<int64_t> ReplayLink::Find() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!plugged_) {
    if (plug_in_) {
      if (absl::Status back = plug_in_(); !back.ok()) return back;
    }
    plugged_ = true;
    ++connection_;
  }
  return connection_;
}

bool ReplayLink::Up(int64_t connection) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return plugged_ && connection == connection_;
}

void ReplayLink::Unplug() {
  std::lock_guard<std::mutex> lock(mutex_);
  plugged_ = false;
}

ReplayApi::ReplayApi(CameraDump dump, FrameSource frames,
                     std::shared_ptr<ReplayLink> link, FrameSource previews)
    : dump_(std::move(dump)),
      frames_(std::move(frames)),
      link_(link != nullptr ? std::move(link) : std::make_shared<ReplayLink>()),
      previews_(std::move(previews)) {
  widgets_ = dump_.widgets;
}

std::string ReplayApi::Port() const {
  return absl::StrCat("replay:", dump_.source);
}

int ReplayApi::Fail(int code, std::string text) {
  last_error_ = std::move(text);
  return code;
}

int ReplayApi::CheckLink() {
  if (link_->Up(connection_)) return GP_OK;
  return Fail(GP_ERROR_IO,
              connection_ == 0
                  ? "the replay camera is not open"
                  : absl::StrCat("the replayed camera was unplugged (",
                                 dump_.source, ")"));
}

int ReplayApi::Autodetect(std::vector<DetectedCamera>* cameras) {
  cameras->clear();
  if (link_->Find().ok()) cameras->push_back({dump_.model, Port()});
  return GP_OK;
}

int ReplayApi::CheckModel(const std::string& model) {
  if (absl::EqualsIgnoreCase(model, dump_.model)) return GP_OK;
  return Fail(GP_ERROR_MODEL_NOT_FOUND,
              absl::StrCat("the replay knows \"", dump_.model, "\" only"));
}

int ReplayApi::Open(const std::string& model, const std::string& port) {
  absl::StatusOr<int64_t> connection = link_->Find();
  if (!connection.ok()) {
    return Fail(GP_ERROR_IO_USB_FIND,
                std::string(connection.status().message()));
  }
  if (model != dump_.model || port != Port()) {
    return Fail(
        GP_ERROR_MODEL_NOT_FOUND,
        absl::StrCat("the replay holds \"", dump_.model, "\" on ", Port()));
  }
  connection_ = *connection;
  return GP_OK;
}

int ReplayApi::GetSummary(std::string* text) {
  if (int code = CheckLink(); code != GP_OK) return code;
  *text = dump_.summary;
  return GP_OK;
}

int ReplayApi::GetConfig(std::vector<ConfigWidget>* widgets) {
  if (int code = CheckLink(); code != GP_OK) return code;
  *widgets = widgets_;
  return GP_OK;
}

int ReplayApi::SetConfigValue(const std::string& name,
                              const std::string& value) {
  if (int code = CheckLink(); code != GP_OK) return code;
  auto it = std::find_if(widgets_.begin(), widgets_.end(),
                         [&](const ConfigWidget& w) { return w.name == name; });
  if (it == widgets_.end()) {
    return Fail(GP_ERROR_BAD_PARAMETERS,
                absl::StrCat("no widget \"", name, "\" in ", dump_.source));
  }
  if (it->read_only) {
    return Fail(GP_ERROR_NOT_SUPPORTED,
                absl::StrCat(it->path, " is read-only"));
  }
  switch (it->type) {
    case WidgetType::kRadio:
    case WidgetType::kMenu:
      if (std::find(it->choices.begin(), it->choices.end(), value) ==
          it->choices.end()) {
        return Fail(
            GP_ERROR_BAD_PARAMETERS,
            absl::StrCat("\"", value, "\" is not a choice of ", it->path));
      }
      break;
    case WidgetType::kRange: {
      float number = 0;
      if (!absl::SimpleAtof(value, &number) || number < it->min ||
          number > it->max) {
        return Fail(GP_ERROR_BAD_PARAMETERS,
                    absl::StrCat("\"", value, "\" is outside ", it->path, " [",
                                 it->min, ", ", it->max, "]"));
      }
      it->value = absl::StrFormat("%g", number);
      return GP_OK;
    }
    case WidgetType::kToggle:
      if (value != "0" && value != "1") {
        return Fail(GP_ERROR_BAD_PARAMETERS,
                    absl::StrCat(it->path, " takes 0 or 1"));
      }
      break;
    case WidgetType::kDate: {
      int64_t seconds = 0;
      if (!absl::SimpleAtoi(value, &seconds)) {
        return Fail(GP_ERROR_BAD_PARAMETERS,
                    absl::StrCat(it->path, " takes seconds since the epoch"));
      }
      break;
    }
    case WidgetType::kButton:
      return Fail(GP_ERROR_NOT_SUPPORTED,
                  absl::StrCat(it->path, " is a button"));
    case WidgetType::kText:
      break;
  }
  it->value = value;
  return GP_OK;
}

int ReplayApi::FromSource(const FrameSource& source, ReplayFile* file) {
  const hardware::ExposureSettings settings = ReadExposureSettings(widgets_);
  if (!(settings.exposure_s > 0)) {
    return Fail(GP_ERROR_NOT_SUPPORTED,
                "the shutter speed is not a timed exposure (bulb or unknown)");
  }
  absl::StatusOr<ReplayFile> made = source(settings);
  if (!made.ok()) {
    // A source that went away (the simulated camera was unplugged) is what
    // libgphoto2 reports for a camera gone from USB: an I/O error.
    const bool gone = absl::IsAborted(made.status()) ||
                      absl::IsFailedPrecondition(made.status());
    if (gone) link_->Unplug();
    return Fail(gone ? GP_ERROR_IO : GP_ERROR,
                std::string(made.status().message()));
  }
  *file = *std::move(made);
  return GP_OK;
}

int ReplayApi::Capture(std::string* folder, std::string* name) {
  if (int code = CheckLink(); code != GP_OK) return code;
  if (!frames_) {
    return Fail(GP_ERROR_NOT_SUPPORTED,
                "this replay camera has no frame source");
  }
  ReplayFile file;
  if (const int code = FromSource(frames_, &file); code != GP_OK) return code;
  const ConfigWidget* target = FindWidget(widgets_, "capturetarget");
  *folder = target != nullptr && CaptureTargetIsRam(target->value)
                ? kRamFolder
                : kCardFolder;
  *name = absl::StrFormat("capt%04d.%s", captures_++, file.extension);
  files_[{*folder, *name}] = std::move(file.bytes);
  return GP_OK;
}

int ReplayApi::CapturePreview(FileData* file) {
  if (int code = CheckLink(); code != GP_OK) return code;
  if (!previews_) {
    return Fail(GP_ERROR_NOT_SUPPORTED, "this replay camera has no live view");
  }
  ReplayFile frame;
  if (const int code = FromSource(previews_, &frame); code != GP_OK) {
    return code;
  }
  for (ConfigWidget& widget : widgets_) {
    if (std::find(kViewfinderWidgets.begin(), kViewfinderWidgets.end(),
                  widget.name) != kViewfinderWidgets.end()) {
      widget.value = "1";
    }
  }
  file->bytes = std::move(frame.bytes);
  file->mtime = absl::InfinitePast();
  return GP_OK;
}

int ReplayApi::WaitForEvent(absl::Duration /*timeout*/, CameraEvent* event) {
  if (int code = CheckLink(); code != GP_OK) return code;
  *event = CameraEvent();  // one file per capture: nothing else happens
  return GP_OK;
}

int ReplayApi::ListFiles(const std::string& folder,
                         std::vector<std::string>* names) {
  if (int code = CheckLink(); code != GP_OK) return code;
  names->clear();
  for (const auto& [where, bytes] : files_) {
    if (where.first == folder) names->push_back(where.second);
  }
  return GP_OK;
}

int ReplayApi::GetFile(const std::string& folder, const std::string& name,
                       FileData* file) {
  if (int code = CheckLink(); code != GP_OK) return code;
  auto it = files_.find({folder, name});
  if (it == files_.end()) {
    return Fail(GP_ERROR_FILE_NOT_FOUND,
                absl::StrCat(folder, "/", name, " is not on the camera"));
  }
  file->bytes = it->second;
  file->mtime = absl::InfinitePast();
  return GP_OK;
}

int ReplayApi::DeleteFile(const std::string& folder, const std::string& name) {
  if (int code = CheckLink(); code != GP_OK) return code;
  if (files_.erase({folder, name}) == 0) {
    return Fail(GP_ERROR_FILE_NOT_FOUND,
                absl::StrCat(folder, "/", name, " is not on the camera"));
  }
  return GP_OK;
}

void ReplayApi::BeginCall() { last_error_.clear(); }

std::string ReplayApi::ErrorText(int code) {
  std::string text = gp_result_as_string(code);
  if (!last_error_.empty()) absl::StrAppend(&text, " (", last_error_, ")");
  return text;
}

}  // namespace hdrstereo::gphoto2
