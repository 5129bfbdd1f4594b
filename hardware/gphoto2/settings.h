// SPDX-License-Identifier: GPL-3.0-or-later
//
// Pure helpers that turn libgphoto2 widget choices (strings whose spelling
// varies by vendor) into numbers and back: shutter speeds, ISO, f-numbers,
// image formats, capture targets, battery levels. No libgphoto2 here.
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_SETTINGS_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_SETTINGS_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "hardware/camera.h"

namespace hdrstereo::gphoto2 {

// Seconds of a shutter-speed choice: "1/125", "1/125s", "0.5", "2.5s", "30",
// "30\"", "1\"3" (Canon/Sony: 1.3 s), "1\"" (1 s). nullopt for "Bulb",
// "Time", "Auto" and anything unparseable.
std::optional<double> ParseShutterSpeed(absl::string_view choice);

// True for the bulb choice ("bulb", "Bulb", "BULB").
bool IsBulb(absl::string_view choice);

// "1/125 s", "0.3 s", "2.5 s", "30 s"; for messages.
std::string FormatSeconds(double seconds);

struct ShutterChoice {
  std::string choice;  // the camera's spelling, to set the widget with
  double seconds = 0;  // what it means
};

// All timed choices (bulb and unparseable ones skipped), in camera order.
std::vector<ShutterChoice> TimedShutterChoices(
    const std::vector<std::string>& choices);

// The choice nearest to `seconds` in stops (log2 ratio); ties go to the
// shorter exposure. INVALID_ARGUMENT when `seconds` <= 0, when no choice is a
// timed exposure, or when `seconds` lies more than half a stop outside the
// range the camera offers (the message names the range; bulb is never used).
absl::StatusOr<ShutterChoice> NearestShutterSpeed(
    const std::vector<std::string>& choices, double seconds);

// ISO choices: "100", "ISO 100", "100 ISO"; nullopt for "Auto" and garbage.
std::optional<int> ParseIso(absl::string_view choice);
// The choice that means exactly `iso`; INVALID_ARGUMENT listing the choices
// otherwise.
absl::StatusOr<std::string> MatchIso(const std::vector<std::string>& choices,
                                     int iso);

// f-number choices: "f/5.6", "F5.6", "5.6"; nullopt for "implicit auto" etc.
std::optional<double> ParseAperture(absl::string_view choice);
// The choice within 3% of `f_number` (nominal values: 5.6 means f/5.66);
// INVALID_ARGUMENT listing the choices otherwise (they depend on the lens).
absl::StatusOr<std::string> MatchAperture(
    const std::vector<std::string>& choices, double f_number);

// What an image-format/quality choice produces, matched case-insensitively:
// "RAW", "cRAW", "NEF (Raw)" -> kRaw; "Large Fine JPEG", "JPEG Fine",
// "Fine" -> kJpeg; "RAW + Large Fine JPEG", "NEF+Fine", "RAW+JPEG" ->
// kRawAndJpeg; nullopt for anything else (e.g. "TIFF (RGB)").
std::optional<hardware::ImageFormat> ClassifyFormatChoice(
    absl::string_view choice);

// The best choice producing `format`: full-size RAW before mRAW/sRAW, the
// largest and finest JPEG. INVALID_ARGUMENT listing the choices when none
// fits (and always for kTiff16/kPng8, which only the simulator makes).
absl::StatusOr<std::string> MatchFormatChoice(
    const std::vector<std::string>& choices, hardware::ImageFormat format);

// What a downloaded file is, from its name's extension: .jpg/.jpeg -> kJpeg;
// camera RAW extensions (.cr2 .cr3 .nef .arw .dng .raf .orf .rw2 ...) ->
// kRaw; .png -> kPng8; .tif/.tiff -> kTiff16; nullopt otherwise.
std::optional<hardware::ImageFormat> FormatFromFileName(absl::string_view name);
// Lowercase extension without the dot ("" when none).
std::string FileExtension(absl::string_view name);

// Whether a libgphoto2 port is on the network: "ptpip:..." (the only
// network prefix libgphoto2 2.5.30's port library registers).
bool IsNetworkPort(absl::string_view port);
// A camera port as libgphoto2 takes it. For "ptpip:HOST[:PORT[:EVENTS]]"
// HOST must be an IPv4 address (libgphoto2 resolves no names) and the
// ports 1..65535; one PORT serves both connections ("ptpip:H:P" becomes
// "ptpip:H:P:P": libgphoto2 would look for the events on 15740). Other
// ports are returned as given. INVALID_ARGUMENT saying what is wrong.
absl::StatusOr<std::string> NormalizeCameraPort(absl::string_view port);

enum class CaptureTarget {
  kLeaveAsIs,
  kInternalRam,  // the file lives in camera RAM until downloaded; no card
  kMemoryCard,
};
// From a config file or flag: "ram", "card", or "" (leave as is); any case.
absl::StatusOr<CaptureTarget> ParseCaptureTarget(absl::string_view text);
// The `capturetarget` choice for `target` ("Internal RAM", "Memory card");
// INVALID_ARGUMENT listing the choices when none matches.
absl::StatusOr<std::string> MatchCaptureTarget(
    const std::vector<std::string>& choices, CaptureTarget target);
// Whether a `capturetarget` choice keeps captures in camera RAM only (not
// "card", nor "card+sdram").
bool CaptureTargetIsRam(absl::string_view choice);

// "100%", "75 %", "Full" (100), "Low" (10)...; -1 when unknown.
int ParseBatteryPercent(absl::string_view value);

// `"a", "b", "c"` for error messages.
std::string JoinChoices(const std::vector<std::string>& choices);

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_SETTINGS_H_
