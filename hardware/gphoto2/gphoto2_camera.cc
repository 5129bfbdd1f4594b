// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/gphoto2_camera.h"

#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>

#include <algorithm>
#include <condition_variable>
#include <initializer_list>
#include <thread>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "hardware/camera.h"
#include "hardware/gphoto2/libgphoto2_api.h"
#include "hardware/gphoto2/widgets.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::gphoto2 {
namespace {

// "iso (/main/imgsettings/iso)": how messages name a widget.
std::string Named(const ConfigWidget& widget) {
  return absl::StrCat(widget.name, " (", widget.path, ")");
}

// The choice of `widget` that `match` picks from its choices; a widget
// without choices (TEXT, or a radio list the camera left empty) cannot be
// matched that way.
absl::StatusOr<std::string> MatchChoice(
    const ConfigWidget& widget, absl::string_view what,
    const std::function<
        absl::StatusOr<std::string>(const std::vector<std::string>&)>& match) {
  if (widget.choices.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        Named(widget), " offers no choices (current value \"", widget.value,
        "\"): setting the ", what, " through it is not supported"));
  }
  absl::StatusOr<std::string> choice = match(widget.choices);
  if (!choice.ok()) {
    return absl::Status(
        choice.status().code(),
        absl::StrCat(Named(widget), ": ", choice.status().message()));
  }
  return choice;
}

// A number for a range widget (Sony's f-number runs 0 .. 655.35 in steps of
// 0.01; the camera takes the nearest stop the lens has), as the library
// reports a range's value.
absl::StatusOr<std::string> RangeValue(const ConfigWidget& widget,
                                       double value) {
  if (value < widget.min || value > widget.max) {
    return absl::InvalidArgumentError(
        absl::StrCat(Named(widget), ": ", value, " is outside its range [",
                     widget.min, ", ", widget.max, "]"));
  }
  return absl::StrFormat("%g", static_cast<float>(value));
}

std::string JoinPath(const std::string& folder, const std::string& name) {
  if (folder.empty() || absl::EndsWith(folder, "/")) {
    return absl::StrCat(folder, name);
  }
  return absl::StrCat(folder, "/", name);
}

std::string ModeDialHint(absl::string_view name) {
  return absl::StrCat(
      "the camera does not let \"", name,
      "\" be changed now; is the mode dial on M (manual) and the lens set "
      "for this setting?");
}

}  // namespace

absl::Status Gphoto2Error(absl::string_view what, int code,
                          absl::string_view detail) {
  const std::string reason = absl::StrCat(
      detail.empty() ? "libgphoto2 error" : detail, " [", code, "]");
  switch (code) {
    case GP_ERROR_IO_USB_CLAIM:
      return absl::UnavailableError(absl::StrCat(
          what,
          ": could not claim the USB device: another process holds the "
          "camera, usually gvfs-gphoto2-volume-monitor (the desktop's "
          "automounter), a file manager, or another gphoto2; stop it (e.g. "
          "`pkill -f gvfs-gphoto2`) and try again (",
          reason, ")"));
    case GP_ERROR_IO_USB_FIND:
      return absl::UnavailableError(absl::StrCat(
          what,
          ": the camera is not on the USB bus (disconnected: unplugged, "
          "switched off or asleep?) (",
          reason, ")"));
    case GP_ERROR_MODEL_NOT_FOUND:
      return absl::NotFoundError(
          absl::StrCat(what,
                       ": libgphoto2 knows no such camera model (see `gphoto2 "
                       "--list-cameras`) (",
                       reason, ")"));
    case GP_ERROR_UNKNOWN_PORT:
      return absl::NotFoundError(absl::StrCat(
          what, ": no such port (see `gphoto2 --list-ports`) (", reason, ")"));
    case GP_ERROR_CAMERA_BUSY:
      return absl::UnavailableError(
          absl::StrCat(what, ": the camera is busy (", reason, ")"));
    case GP_ERROR_TIMEOUT:
      return absl::DeadlineExceededError(absl::StrCat(
          what, ": the camera did not answer in time (", reason, ")"));
    case GP_ERROR_NOT_SUPPORTED:
      return absl::UnimplementedError(absl::StrCat(
          what, ": not supported by this camera or its driver (", reason, ")"));
    case GP_ERROR_BAD_PARAMETERS:
      return absl::InvalidArgumentError(absl::StrCat(what, ": ", reason));
    case GP_ERROR_CORRUPTED_DATA:
      return absl::DataLossError(absl::StrCat(
          what, ": corrupted data from the camera (", reason, ")"));
    case GP_ERROR_FILE_NOT_FOUND:
    case GP_ERROR_DIRECTORY_NOT_FOUND:
      return absl::NotFoundError(absl::StrCat(what, ": ", reason));
    case GP_ERROR_NO_SPACE:
      return absl::ResourceExhaustedError(absl::StrCat(
          what, ": no space left on the camera's card (", reason, ")"));
    case GP_ERROR_NO_MEMORY:  // also a PTP StoreFull during a capture
      return absl::ResourceExhaustedError(
          absl::StrCat(what,
                       ": out of memory: the camera's storage is full, or this "
                       "computer's memory (",
                       reason, ")"));
    case GP_ERROR_CANCEL:
      return absl::CancelledError(absl::StrCat(what, ": cancelled"));
    default:
      break;
  }
  // The port layer's I/O errors (GP_ERROR_IO and -20 .. -99).
  if (code == GP_ERROR_IO ||
      (code <= GP_ERROR_IO_SUPPORTED_SERIAL && code > -100)) {
    return absl::UnavailableError(absl::StrCat(
        what, ": I/O error talking to the camera (disconnected?) (", reason,
        ")"));
  }
  return absl::UnknownError(absl::StrCat(what, ": ", reason));
}

// Runs the libgphoto2 calls on a thread of their own, so that a caller can
// stop waiting for one. The state lives in a shared_ptr that the thread
// holds too: a detached thread stuck in a call keeps the api alive and
// destroys it (closing the camera) when the call returns.
class Gphoto2Camera::Worker {
 public:
  struct Outcome {
    int code = GP_OK;
    std::string error_text;
  };

  // `cancel_grace`: how long a call that timed out is given to return once
  // asked to cancel.
  Worker(std::unique_ptr<Gphoto2Api> api, absl::Duration cancel_grace)
      // InfiniteDuration would overflow the condition variable's clock.
      : cancel_grace_(std::min(cancel_grace, absl::Hours(24 * 365))),
        state_(std::make_shared<State>()) {
    state_->api = std::move(api);
    thread_ = std::thread(&Worker::Loop, state_);
  }

  ~Worker() {
    bool stuck = false;
    {
      std::unique_lock<std::mutex> lock(state_->mutex);
      stuck = state_->stuck;
      if (!stuck) {
        state_->cv.wait(lock,
                        [&] { return !state_->running && !state_->task; });
      }
      state_->stop = true;
      state_->cv.notify_all();
    }
    if (stuck) {
      thread_.detach();
    } else {
      thread_.join();
    }
  }

  absl::StatusOr<Outcome> Run(absl::string_view what, absl::Duration timeout,
                              std::function<int(Gphoto2Api&)> fn) {
    // InfiniteDuration would overflow the condition variable's clock.
    timeout = std::min(timeout, absl::Hours(24 * 365));
    auto outcome = std::make_shared<Outcome>();
    auto finished = std::make_shared<bool>(false);
    auto abandoned = std::make_shared<bool>(false);
    std::unique_lock<std::mutex> lock(state_->mutex);
    if (state_->stuck) {
      return hardware::CameraStuckError(absl::UnavailableError(absl::StrCat(
          "cannot ", what, ": the camera is still stuck in \"",
          state_->stuck_call, "\", which timed out ",
          absl::FormatDuration(absl::Now() - state_->stuck_since),
          " ago; libgphoto2 has not returned yet (unplug the camera or "
          "switch it off and on if this lasts)")));
    }
    // The previous call may still be winding up on the worker.
    state_->cv.wait(lock, [&] { return !state_->running && !state_->task; });
    State* state = state_.get();
    state_->task = [state, outcome, finished, abandoned, fn = std::move(fn)]() {
      {
        // Under the lock that the caller's timeout takes: either the caller
        // gave up before the call began (skip it), or BeginCall() comes
        // before the caller's Cancel() (which then reaches the call).
        std::lock_guard<std::mutex> start_lock(state->mutex);
        if (*abandoned) {
          *finished = true;  // skipped: over, with no outcome
          state->cv.notify_all();
          return;
        }
        state->api->BeginCall();
      }
      int code = fn(*state->api);
      std::string text = code < GP_OK ? state->api->ErrorText(code) : "";
      std::lock_guard<std::mutex> done_lock(state->mutex);
      outcome->code = code;
      outcome->error_text = std::move(text);
      *finished = true;
      state->cv.notify_all();
    };
    state_->cv.notify_all();
    if (!state_->cv.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                             [&] { return *finished; })) {
      *abandoned = true;
      state_->api->Cancel();
      const std::string late =
          absl::StrCat(what, ": no answer from the camera within ",
                       absl::FormatDuration(timeout));
      if (state_->cv.wait_for(lock, absl::ToChronoNanoseconds(cancel_grace_),
                              [&] { return *finished; })) {
        return absl::DeadlineExceededError(
            absl::StrCat(late, "; the call was cancelled"));
      }
      state_->stuck = true;
      state_->stuck_call = std::string(what);
      state_->stuck_since = absl::Now();
      return hardware::CameraStuckError(absl::DeadlineExceededError(
          absl::StrCat(late,
                       "; it was asked to cancel, but libgphoto2 has "
                       "not returned within ",
                       absl::FormatDuration(cancel_grace_),
                       ": the camera is unusable until it does")));
    }
    return *outcome;
  }

  HandleWatch Watch() const {
    return [state = state_]() -> std::optional<HandleUse> {
      std::lock_guard<std::mutex> lock(state->mutex);
      if (state->closed) return std::nullopt;
      if (!state->stuck) return HandleUse{};
      return HandleUse{.stuck_call = state->stuck_call,
                       .stuck_since = state->stuck_since};
    };
  }

 private:
  struct State {
    std::unique_ptr<Gphoto2Api> api;
    std::mutex mutex;
    std::condition_variable cv;
    std::function<void()> task;  // the next call to run
    bool running = false;        // a call is running
    bool stop = false;
    bool stuck = false;      // the running call timed out
    std::string stuck_call;  // which one
    absl::Time stuck_since;
    bool closed = false;  // the api is destroyed (the camera closed)
  };

  static void Loop(std::shared_ptr<State> state) {
    std::unique_lock<std::mutex> lock(state->mutex);
    while (true) {
      state->cv.wait(lock, [&] { return state->stop || state->task; });
      if (state->task == nullptr) break;  // stopping
      std::function<void()> task = std::move(state->task);
      state->task = nullptr;
      state->running = true;
      lock.unlock();
      task();
      task = nullptr;
      lock.lock();
      state->running = false;
      state->stuck = false;
      state->cv.notify_all();
    }
    // Stopping, so no caller is left to use the api: close the camera
    // here, also on a detached thread, and say so (WatchHandle).
    lock.unlock();
    state->api.reset();
    lock.lock();
    state->closed = true;
  }

  const absl::Duration cancel_grace_;
  std::shared_ptr<State> state_;
  std::thread thread_;
};

Gphoto2Camera::Gphoto2Camera(const Gphoto2Options& options,
                             std::unique_ptr<Gphoto2Api> api)
    : options_(options),
      worker_(std::make_unique<Worker>(std::move(api), options.cancel_grace)),
      delivered_format_(options.fixed_format) {}

Gphoto2Camera::~Gphoto2Camera() = default;

Gphoto2Camera::HandleWatch Gphoto2Camera::WatchHandle() const {
  return worker_->Watch();
}

absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Gphoto2Camera::Open(
    const Gphoto2Options& options) {
  return OpenWithApi(options, NewLibgphoto2Api());
}

absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Gphoto2Camera::OpenWithApi(
    const Gphoto2Options& options, std::unique_ptr<Gphoto2Api> api) {
  if (api == nullptr) return absl::InvalidArgumentError("gphoto2: no api");
  std::unique_ptr<Gphoto2Camera> camera(
      new Gphoto2Camera(options, std::move(api)));
  std::string model = options.model;
  std::string port = options.port;
  if (!model.empty()) {
    // A model libgphoto2 has no driver for is never found: say so now.
    RETURN_IF_ERROR(camera->Call(
        absl::StrCat("look up camera model \"", model, "\""),
        options.call_timeout,
        [model](Gphoto2Api& api) { return api.CheckModel(model); }));
  }
  if (model.empty() || port.empty()) {
    auto detected = std::make_shared<std::vector<DetectedCamera>>();
    RETURN_IF_ERROR(camera->Call("autodetect cameras", options.call_timeout,
                                 [detected](Gphoto2Api& api) {
                                   return api.Autodetect(detected.get());
                                 }));
    if (detected->empty()) {
      return absl::UnavailableError(
          "no camera found: libgphoto2's autodetect lists none. Is the camera "
          "connected by USB, switched on and awake, and in PTP/PC mode (not "
          "mass storage)? `gphoto2 --auto-detect` should list it.");
    }
    const DetectedCamera* match = nullptr;
    for (const DetectedCamera& candidate : *detected) {
      if ((model.empty() || absl::EqualsIgnoreCase(candidate.model, model)) &&
          (port.empty() || candidate.port == port)) {
        match = &candidate;
        break;
      }
    }
    if (match == nullptr) {
      std::vector<std::string> found;
      for (const DetectedCamera& candidate : *detected) {
        found.push_back(
            absl::StrCat("\"", candidate.model, "\" on ", candidate.port));
      }
      return absl::UnavailableError(absl::StrCat(
          "no camera matching", model.empty() ? "" : " model \"", model,
          model.empty() ? "" : "\"", port.empty() ? "" : " on port ", port,
          "; found: ", absl::StrJoin(found, ", ")));
    }
    model = match->model;
    port = match->port;
  }
  absl::Status status = camera->Call(
      absl::StrCat("open \"", model, "\" on ", port), options.call_timeout,
      [model, port](Gphoto2Api& api) { return api.Open(model, port); });
  if (!status.ok()) return status;
  camera->model_ = model;
  camera->port_ = port;

  std::lock_guard<std::mutex> lock(camera->mutex_);
  if (options.capture_target != CaptureTarget::kLeaveAsIs) {
    status = camera->SetCaptureTargetLocked(options.capture_target);
    // Cameras without configuration or without the widget keep their own.
    if (!status.ok() && !absl::IsUnimplemented(status) &&
        !absl::IsNotFound(status)) {
      return status;
    }
  }
  // Remember the exposure and format in effect; fine to fail (no config).
  camera->SettingsLocked().IgnoreError();
  return camera;
}

absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Gphoto2Camera::Reopen(
    const Gphoto2Options& options, const std::string& serial,
    const ApiFactory& new_api) {
  // A network camera keeps its address (and autodetect does not look on
  // the network): it is reopened where it was, and must be the same body.
  if (IsNetworkPort(options.port)) {
    ASSIGN_OR_RETURN(std::unique_ptr<Gphoto2Camera> camera,
                     OpenWithApi(options, new_api()));
    absl::StatusOr<hardware::CameraInfo> info = camera->Info();
    if (serial.empty() || (info.ok() && info->serial == serial)) return camera;
    return absl::UnavailableError(
        absl::StrCat("the camera at ", options.port,
                     " is not the one with serial number \"", serial, "\" (",
                     info.ok() ? absl::StrCat("it has \"", info->serial, "\"")
                               : std::string(info.status().message()),
                     ")"));
  }
  Gphoto2Options search = options;
  search.port.clear();
  if (serial.empty()) return OpenWithApi(search, new_api());
  std::vector<DetectedCamera> detected;
  {
    std::unique_ptr<Gphoto2Camera> probe(new Gphoto2Camera(search, new_api()));
    auto found = std::make_shared<std::vector<DetectedCamera>>();
    RETURN_IF_ERROR(probe->Call(
        "autodetect cameras", search.call_timeout,
        [found](Gphoto2Api& api) { return api.Autodetect(found.get()); }));
    detected = std::move(*found);
  }
  std::vector<std::string> seen;
  for (const DetectedCamera& candidate : detected) {
    if (!search.model.empty() &&
        !absl::EqualsIgnoreCase(candidate.model, search.model)) {
      seen.push_back(absl::StrCat("\"", candidate.model, "\" on ",
                                  candidate.port, " (another model)"));
      continue;
    }
    Gphoto2Options exact = search;
    exact.model = candidate.model;
    exact.port = candidate.port;
    absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
        OpenWithApi(exact, new_api());
    if (!camera.ok()) {
      seen.push_back(absl::StrCat("\"", candidate.model, "\" on ",
                                  candidate.port, " (",
                                  camera.status().message(), ")"));
      continue;
    }
    absl::StatusOr<hardware::CameraInfo> info = (*camera)->Info();
    if (info.ok() && info->serial == serial) return camera;
    seen.push_back(absl::StrCat(
        "\"", candidate.model, "\" on ", candidate.port, " (",
        info.ok() ? absl::StrCat("serial number \"", info->serial, "\"")
                  : std::string(info.status().message()),
        ")"));
  }
  return absl::UnavailableError(absl::StrCat(
      "no camera with serial number \"", serial, "\"",
      search.model.empty() ? "" : absl::StrCat(" (", search.model, ")"),
      "; found: ", seen.empty() ? "none" : absl::StrJoin(seen, ", ")));
}

absl::Status Gphoto2Camera::Call(absl::string_view what, absl::Duration timeout,
                                 std::function<int(Gphoto2Api&)> fn) {
  absl::Duration backoff = options_.busy_backoff;
  const absl::Time start = absl::Now();
  for (int attempt = 0;; ++attempt) {
    ASSIGN_OR_RETURN(Worker::Outcome outcome, worker_->Run(what, timeout, fn));
    if (outcome.code >= GP_OK) return absl::OkStatus();
    if (outcome.code != GP_ERROR_CAMERA_BUSY) {
      if (outcome.code == GP_ERROR && IsNetworkPort(port_)) {
        // libgphoto2's PTP/IP reports a connection the camera closed as a
        // plain GP_ERROR ("Unspecified error"), not as an I/O error.
        absl::Status answers = StillAnswers();
        if (hardware::IsCameraStuck(answers)) return answers;
        if (!answers.ok()) {
          return absl::UnavailableError(
              absl::StrCat(what, ": the network camera at ", port_,
                           " closed the connection (disconnected) (",
                           outcome.error_text, " [", outcome.code, "])"));
        }
      }
      return Gphoto2Error(what, outcome.code, outcome.error_text);
    }
    if (attempt >= options_.busy_retries) {
      return absl::UnavailableError(
          absl::StrCat(what, ": the camera stayed busy (", outcome.error_text,
                       ") through ", attempt + 1, " tries over ",
                       absl::FormatDuration(absl::Now() - start)));
    }
    absl::SleepFor(backoff);
    backoff = std::min(backoff * 2, options_.busy_backoff_max);
  }
}

absl::Status Gphoto2Camera::StillAnswers() {
  constexpr char kWhat[] = "check that the camera still answers";
  ASSIGN_OR_RETURN(
      Worker::Outcome outcome,
      worker_->Run(kWhat, options_.call_timeout, [](Gphoto2Api& api) {
        std::string summary;
        return api.GetSummary(&summary);
      }));
  if (outcome.code >= GP_OK) return absl::OkStatus();
  return Gphoto2Error(kWhat, outcome.code, outcome.error_text);
}

absl::StatusOr<std::vector<ConfigWidget>> Gphoto2Camera::ConfigLocked() {
  auto widgets = std::make_shared<std::vector<ConfigWidget>>();
  RETURN_IF_ERROR(Call(
      "read the camera configuration", options_.call_timeout,
      [widgets](Gphoto2Api& api) { return api.GetConfig(widgets.get()); }));
  return std::move(*widgets);
}

absl::Status Gphoto2Camera::SetLocked(const std::string& name,
                                      const std::string& value) {
  return Call(absl::StrCat("set ", name, " to \"", value, "\""),
              options_.call_timeout, [name, value](Gphoto2Api& api) {
                return api.SetConfigValue(name, value);
              });
}

absl::StatusOr<hardware::ExposureSettings> Gphoto2Camera::SettingsLocked() {
  ASSIGN_OR_RETURN(std::vector<ConfigWidget> widgets, ConfigLocked());
  const hardware::ExposureSettings settings = ReadExposureSettings(widgets);
  exposure_s_ = settings.exposure_s;
  format_ = settings.format;
  has_capture_target_ = FindWidget(widgets, "capturetarget") != nullptr;
  return settings;
}

absl::StatusOr<hardware::ExposureSettings> Gphoto2Camera::Settings() {
  std::lock_guard<std::mutex> lock(mutex_);
  return SettingsLocked();
}

absl::StatusOr<hardware::CameraInfo> Gphoto2Camera::Info() {
  std::lock_guard<std::mutex> lock(mutex_);
  hardware::CameraInfo info;
  info.model = model_;
  info.port = port_;
  absl::StatusOr<std::vector<ConfigWidget>> widgets = ConfigLocked();
  if (absl::IsUnimplemented(widgets.status())) return info;  // no config
  if (!widgets.ok()) return widgets.status();
  for (absl::string_view name : {"cameramodel", "model"}) {
    const ConfigWidget* widget = FindWidget(*widgets, name);
    if (widget != nullptr && !widget->value.empty()) {
      info.model = widget->value;
      break;
    }
  }
  if (const ConfigWidget* serial = FindWidget(*widgets, "serialnumber")) {
    info.serial = serial->value;
  }
  if (const ConfigWidget* battery = FindWidget(*widgets, "batterylevel")) {
    info.battery_percent = ParseBatteryPercent(battery->value);
  }
  if (const ConfigWidget* shutter = FindShutterWidget(*widgets)) {
    for (const ShutterChoice& choice : TimedShutterChoices(shutter->choices)) {
      info.shutter_speeds_s.push_back(choice.seconds);
    }
    std::sort(info.shutter_speeds_s.begin(), info.shutter_speeds_s.end());
    info.shutter_speeds_s.erase(
        std::unique(info.shutter_speeds_s.begin(), info.shutter_speeds_s.end()),
        info.shutter_speeds_s.end());
    if (!info.shutter_speeds_s.empty()) {
      info.min_exposure_s = info.shutter_speeds_s.front();
      info.max_exposure_s = info.shutter_speeds_s.back();
    }
  }
  return info;
}

absl::StatusOr<hardware::ExposureSettings> Gphoto2Camera::Configure(
    const hardware::ExposureSettings& settings) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!(settings.exposure_s > 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("exposure must be a positive number of seconds, not ",
                     settings.exposure_s));
  }
  if (settings.iso < 0 || settings.aperture_f < 0) {
    return absl::InvalidArgumentError("ISO and f-number must not be negative");
  }
  ASSIGN_OR_RETURN(std::vector<ConfigWidget> widgets, ConfigLocked());

  // Plan every change first: nothing is set unless all of it is valid.
  struct Change {
    const ConfigWidget* widget;
    std::string value;
  };
  std::vector<Change> plan;
  const ConfigWidget* shutter = FindShutterWidget(widgets);
  if (shutter == nullptr) {
    // Cameras hide the shutter speed, or offer only "auto", outside M.
    std::string mode_hint = "; is the mode dial on M (manual)?";
    if (const ConfigWidget* mode = FindWidget(widgets, kModeWidgets)) {
      mode_hint =
          absl::StrCat("; the exposure program ", Named(*mode), " is \"",
                       mode->value, "\": set the mode dial to M (manual)");
    }
    const ConfigWidget* untimed = FindWidget(widgets, kShutterWidgets);
    if (untimed != nullptr) {
      return absl::FailedPreconditionError(absl::StrCat(
          "the camera's shutter-speed setting ", Named(*untimed),
          " offers no timed exposure (choices: ", JoinChoices(untimed->choices),
          ")", mode_hint));
    }
    return absl::FailedPreconditionError(
        absl::StrCat("the camera has no shutter-speed setting ",
                     WidgetNames(kShutterWidgets), mode_hint,
                     " (some compact cameras have none)"));
  }
  absl::StatusOr<ShutterChoice> speed =
      NearestShutterSpeed(shutter->choices, settings.exposure_s);
  if (!speed.ok()) {
    return absl::Status(
        speed.status().code(),
        absl::StrCat(Named(*shutter), ": ", speed.status().message()));
  }
  plan.push_back({shutter, speed->choice});
  if (settings.iso > 0) {
    const ConfigWidget* iso = FindWidget(widgets, kIsoWidgets);
    if (iso == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat(
          "the camera has no ISO setting ", WidgetNames(kIsoWidgets)));
    }
    ASSIGN_OR_RETURN(
        std::string choice,
        MatchChoice(*iso, "ISO", [&](const std::vector<std::string>& c) {
          return MatchIso(c, settings.iso);
        }));
    plan.push_back({iso, choice});
  }
  if (settings.aperture_f > 0) {
    const ConfigWidget* aperture = FindWidget(widgets, kApertureWidgets);
    if (aperture == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("the camera has no aperture setting ",
                       WidgetNames(kApertureWidgets), " (manual lens?)"));
    }
    ASSIGN_OR_RETURN(std::string choice,
                     aperture->type == WidgetType::kRange
                         ? RangeValue(*aperture, settings.aperture_f)
                         : MatchChoice(*aperture, "f-number",
                                       [&](const std::vector<std::string>& c) {
                                         return MatchAperture(
                                             c, settings.aperture_f);
                                       }));
    plan.push_back({aperture, choice});
  }
  // A camera without a format setting (a generic PTP camera) delivers one
  // format: any is taken until a file shows which, and Capture() refuses a
  // file of another format.
  std::optional<hardware::ImageFormat> fixed_format_asked;
  const ConfigWidget* format = settings.format.has_value()
                                   ? FindWidget(widgets, kFormatWidgets)
                                   : nullptr;
  if (settings.format.has_value() && format == nullptr) {
    if (delivered_format_.has_value() &&
        *delivered_format_ != *settings.format) {
      return absl::InvalidArgumentError(
          absl::StrCat("the camera has no image format setting ",
                       WidgetNames(kFormatWidgets), " and delivers ",
                       hardware::ImageFormatName(*delivered_format_), ", not ",
                       hardware::ImageFormatName(*settings.format)));
    }
    fixed_format_asked = settings.format;
  }
  if (format != nullptr) {
    ASSIGN_OR_RETURN(std::string choice,
                     MatchChoice(*format, "image format",
                                 [&](const std::vector<std::string>& c) {
                                   return MatchFormatChoice(c,
                                                            *settings.format);
                                 }));
    plan.push_back({format, choice});
  }
  for (const Change& change : plan) {
    if (change.widget->value == change.value) continue;
    if (change.widget->read_only) {
      return absl::FailedPreconditionError(
          absl::StrCat(change.widget->name,
                       " is read-only: ", ModeDialHint(change.widget->name)));
    }
  }

  for (const Change& change : plan) {
    if (change.widget->value == change.value) continue;
    RETURN_IF_ERROR(SetLocked(change.widget->name, change.value));
  }

  if (settings.format.has_value()) fixed_format_asked_ = fixed_format_asked;

  // Read back: the camera may ignore a value (wrong mode) without an error.
  ASSIGN_OR_RETURN(std::vector<ConfigWidget> after, ConfigLocked());
  for (const Change& change : plan) {
    const ConfigWidget* now = FindWidget(after, change.widget->name);
    if (now != nullptr && now->value != change.value) {
      return absl::FailedPreconditionError(
          absl::StrCat("the camera kept ", change.widget->name, " at \"",
                       now->value, "\" instead of \"", change.value,
                       "\": ", ModeDialHint(change.widget->name)));
    }
  }
  return SettingsLocked();
}

absl::StatusOr<hardware::Frame> Gphoto2Camera::Capture() {
  std::lock_guard<std::mutex> lock(mutex_);
  RETURN_IF_ERROR(LeaveLiveViewLocked());
  auto path = std::make_shared<std::pair<std::string, std::string>>();
  absl::Status status =
      Call("capture", options_.capture_timeout + absl::Seconds(exposure_s_),
           [path](Gphoto2Api& api) {
             return api.Capture(&path->first, &path->second);
           });
  if (!status.ok()) {
    if (absl::IsUnknown(status)) {  // e.g. -1 "Unspecified error"
      return absl::UnknownError(absl::StrCat(
          status.message(),
          "; if the camera could not focus, switch the lens to MF; check "
          "the card, the capture target and the mode dial"));
    }
    return status;
  }
  std::vector<std::pair<std::string, std::string>> files = {*path};

  // RAW+JPEG: the second file is announced as an event.
  const bool two_files = format_ == hardware::ImageFormat::kRawAndJpeg;
  if (two_files) {
    const absl::Time deadline = absl::Now() + options_.second_file_timeout;
    while (files.size() < 2 && absl::Now() < deadline) {
      auto event = std::make_shared<CameraEvent>();
      absl::Duration wait = deadline - absl::Now();
      status =
          Call("wait for the second file of a RAW+JPEG capture",
               wait + options_.call_timeout, [event, wait](Gphoto2Api& api) {
                 return api.WaitForEvent(wait, event.get());
               });
      if (!status.ok() || event->type == EventType::kTimeout) break;
      if (event->type == EventType::kFileAdded) {
        files.emplace_back(event->folder, event->name);
      }
    }
  }
  // The RAW file when there is one.
  auto chosen = files.begin();
  for (auto it = files.begin(); it != files.end(); ++it) {
    if (FormatFromFileName(it->second) == hardware::ImageFormat::kRaw) {
      chosen = it;
      break;
    }
  }
  // A camera without a format setting that sent another format than asked
  // (its file name says which): the file is deleted, not downloaded.
  const std::optional<hardware::ImageFormat> named =
      FormatFromFileName(chosen->second);
  if (named.has_value()) delivered_format_ = named;
  absl::StatusOr<hardware::Frame> frame;
  if (named.has_value() && fixed_format_asked_.has_value() &&
      *named != *fixed_format_asked_) {
    frame = absl::FailedPreconditionError(absl::StrCat(
        "the camera delivered ", JoinPath(chosen->first, chosen->second),
        " as ", hardware::ImageFormatName(*named), ", not ",
        hardware::ImageFormatName(*fixed_format_asked_),
        ", and has no image format setting to change that"));
  } else {
    frame = DownloadLocked(chosen->first, chosen->second);
    if (!frame.ok()) return frame.status();  // the files stay on the camera
  }
  if (options_.delete_after_download) {
    for (const auto& [folder, name] : files) {
      absl::Status deleted =
          Call(absl::StrCat("delete ", JoinPath(folder, name)),
               options_.call_timeout,
               [folder = folder, name = name](Gphoto2Api& api) {
                 return api.DeleteFile(folder, name);
               });
      if (!deleted.ok()) undeleted_files_.push_back(JoinPath(folder, name));
    }
  }
  return frame;
}

absl::StatusOr<hardware::Frame> Gphoto2Camera::Preview() {
  std::lock_guard<std::mutex> lock(mutex_);
  // Even a preview that fails may have started live view.
  live_view_ = true;
  auto file = std::make_shared<FileData>();
  RETURN_IF_ERROR(
      Call("capture a live-view frame", options_.preview_timeout,
           [file](Gphoto2Api& api) { return api.CapturePreview(file.get()); }));
  // Every JPEG starts with the SOI marker FF D8.
  if (file->bytes.size() < 2 || file->bytes[0] != '\xff' ||
      file->bytes[1] != '\xd8') {
    return absl::DataLossError(
        absl::StrCat("the camera's live-view frame is not a JPEG (",
                     file->bytes.size(), " bytes)"));
  }
  hardware::Frame frame;
  frame.bytes = std::move(file->bytes);
  frame.format = hardware::ImageFormat::kJpeg;
  frame.extension = "jpg";
  frame.exposure_s = exposure_s_;
  return frame;
}

absl::Status Gphoto2Camera::LeaveLiveViewLocked() {
  if (!live_view_) return absl::OkStatus();
  absl::StatusOr<std::vector<ConfigWidget>> widgets = ConfigLocked();
  if (absl::IsUnimplemented(widgets.status())) {  // no configuration at all
    live_view_ = false;
    return absl::OkStatus();
  }
  if (!widgets.ok()) {
    return absl::Status(widgets.status().code(),
                        absl::StrCat("leaving live view before the capture: ",
                                     widgets.status().message()));
  }
  const ConfigWidget* viewfinder = FindWidget(*widgets, kViewfinderWidgets);
  if (viewfinder != nullptr && viewfinder->value != "0") {
    if (absl::Status s = SetLocked(viewfinder->name, "0"); !s.ok()) {
      return absl::Status(
          s.code(),
          absl::StrCat("leaving live view before the capture (the mirror "
                       "would stay up): ",
                       s.message()));
    }
  }
  live_view_ = false;
  return absl::OkStatus();
}

absl::StatusOr<hardware::Frame> Gphoto2Camera::DownloadLocked(
    const std::string& folder, const std::string& name) {
  const std::string path = JoinPath(folder, name);
  std::optional<hardware::ImageFormat> format = FormatFromFileName(name);
  if (!format.has_value()) {
    return absl::FailedPreconditionError(
        absl::StrCat(path,
                     " is not a JPEG, camera RAW, PNG or TIFF file; set "
                     "the image format to raw, jpeg or raw+jpeg"));
  }
  auto file = std::make_shared<FileData>();
  RETURN_IF_ERROR(Call(absl::StrCat("download ", path),
                       options_.download_timeout,
                       [folder, name, file](Gphoto2Api& api) {
                         return api.GetFile(folder, name, file.get());
                       }));
  if (file->bytes.empty()) {
    return absl::DataLossError(absl::StrCat("downloaded ", path, " is empty"));
  }
  hardware::Frame frame;
  frame.bytes = std::move(file->bytes);
  frame.format = *format;
  frame.extension = FileExtension(name);
  frame.exposure_s = exposure_s_;
  frame.camera_time = file->mtime;
  frame.camera_file_name = name;
  // With a capture target to set, card storage shows as
  // /store_XXXXXXXX/... and RAM captures come from "/". A camera without
  // one (a generic PTP camera) keeps every file in a store of its own.
  if (has_capture_target_) {
    frame.stored_to = absl::StartsWith(folder, "/store_")
                          ? hardware::StoredTo::kCard
                          : hardware::StoredTo::kRam;
  }
  return frame;
}

absl::StatusOr<int> Gphoto2Camera::PrepareCaptureGroup() {
  std::lock_guard<std::mutex> lock(mutex_);
  absl::Status target = SetCaptureTargetLocked(options_.capture_target);
  if (!target.ok() && !absl::IsNotFound(target)) return target;
  // Files the camera announced but nobody took (an earlier capture that
  // timed out, a shot from the body's button) would otherwise be taken for
  // the next frame: delete them. Bounded: at most 64 events.
  int discarded = 0;
  for (int i = 0; i < 64; ++i) {
    auto event = std::make_shared<CameraEvent>();
    const absl::Duration wait = options_.drain_event_wait;
    RETURN_IF_ERROR(Call("drain pending camera events",
                         wait + options_.call_timeout,
                         [event, wait](Gphoto2Api& api) {
                           return api.WaitForEvent(wait, event.get());
                         }));
    if (event->type == EventType::kTimeout) break;
    if (event->type != EventType::kFileAdded) continue;
    Call(absl::StrCat("delete pending ", JoinPath(event->folder, event->name)),
         options_.call_timeout,
         [folder = event->folder, name = event->name](Gphoto2Api& api) {
           return api.DeleteFile(folder, name);
         })
        .IgnoreError();
    ++discarded;
  }
  return discarded;
}

absl::StatusOr<std::vector<ConfigWidget>> Gphoto2Camera::Config() {
  std::lock_guard<std::mutex> lock(mutex_);
  return ConfigLocked();
}

absl::StatusOr<std::string> Gphoto2Camera::Summary() {
  std::lock_guard<std::mutex> lock(mutex_);
  auto text = std::make_shared<std::string>();
  RETURN_IF_ERROR(
      Call("read the camera summary", options_.call_timeout,
           [text](Gphoto2Api& api) { return api.GetSummary(text.get()); }));
  return *text;
}

absl::Status Gphoto2Camera::SetConfigValue(const std::string& name,
                                           const std::string& value) {
  std::lock_guard<std::mutex> lock(mutex_);
  ASSIGN_OR_RETURN(std::vector<ConfigWidget> widgets, ConfigLocked());
  const ConfigWidget* widget = FindWidget(widgets, name);
  if (widget == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("the camera has no setting \"", name, "\""));
  }
  if ((widget->type == WidgetType::kRadio ||
       widget->type == WidgetType::kMenu) &&
      !widget->choices.empty() &&
      std::find(widget->choices.begin(), widget->choices.end(), value) ==
          widget->choices.end()) {
    return absl::InvalidArgumentError(
        absl::StrCat("\"", value, "\" is not a choice of ", name,
                     "; choices: ", JoinChoices(widget->choices)));
  }
  if (widget->read_only) {
    return absl::FailedPreconditionError(
        absl::StrCat(name, " is read-only: ", ModeDialHint(name)));
  }
  return SetLocked(name, value);
}

absl::Status Gphoto2Camera::SetCaptureTargetLocked(CaptureTarget target) {
  if (target == CaptureTarget::kLeaveAsIs) return absl::OkStatus();
  ASSIGN_OR_RETURN(std::vector<ConfigWidget> widgets, ConfigLocked());
  const ConfigWidget* widget = FindWidget(widgets, "capturetarget");
  has_capture_target_ = widget != nullptr;
  if (widget == nullptr) {
    return absl::NotFoundError("the camera has no capturetarget setting");
  }
  ASSIGN_OR_RETURN(std::string choice,
                   MatchCaptureTarget(widget->choices, target));
  if (widget->value == choice) return absl::OkStatus();
  return SetLocked("capturetarget", choice);
}

absl::Status Gphoto2Camera::SetCaptureTarget(CaptureTarget target) {
  std::lock_guard<std::mutex> lock(mutex_);
  absl::Status status = SetCaptureTargetLocked(target);
  if (absl::IsNotFound(status)) {
    return absl::InvalidArgumentError(status.message());
  }
  return status;
}

absl::StatusOr<std::vector<std::string>> Gphoto2Camera::ListFiles(
    const std::string& folder) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto names = std::make_shared<std::vector<std::string>>();
  RETURN_IF_ERROR(Call(absl::StrCat("list files in ", folder),
                       options_.call_timeout, [folder, names](Gphoto2Api& api) {
                         return api.ListFiles(folder, names.get());
                       }));
  return *names;
}

absl::StatusOr<hardware::Frame> Gphoto2Camera::Download(
    const std::string& folder, const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  return DownloadLocked(folder, name);
}

absl::Status Gphoto2Camera::DeleteFile(const std::string& folder,
                                       const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  return Call(
      absl::StrCat("delete ", JoinPath(folder, name)), options_.call_timeout,
      [folder, name](Gphoto2Api& api) { return api.DeleteFile(folder, name); });
}

std::vector<std::string> Gphoto2Camera::undeleted_files() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return undeleted_files_;
}

}  // namespace hdrstereo::gphoto2
