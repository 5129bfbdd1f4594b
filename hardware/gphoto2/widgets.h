// SPDX-License-Identifier: GPL-3.0-or-later
//
// Which widget of a camera's configuration tree holds which setting, and
// what the tree's current values mean. Shared by the driver and the replay
// camera, so both read a tree the same way. No libgphoto2 here.
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_WIDGETS_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_WIDGETS_H_

#include <initializer_list>
#include <string>
#include <vector>

#include "absl/strings/string_view.h"
#include "hardware/camera.h"
#include "hardware/gphoto2/gphoto2_api.h"

namespace hdrstereo::gphoto2 {

// Widget names per setting, in order of preference (vendors differ).
inline constexpr std::initializer_list<absl::string_view> kShutterWidgets = {
    "shutterspeed", "shutterspeed2", "exposuretime"};
inline constexpr std::initializer_list<absl::string_view> kIsoWidgets = {
    "iso", "isospeed"};
inline constexpr std::initializer_list<absl::string_view> kApertureWidgets = {
    "aperture", "f-number", "fnumber"};
inline constexpr std::initializer_list<absl::string_view> kFormatWidgets = {
    "imageformat", "imagequality"};
// What holds a camera in live view (Nikon and newer Canon bodies
// "viewfinder", older Canon EOS "eosviewfinder"): a toggle, 1 while live
// view runs; setting it to 0 lowers the mirror and ends live view.
inline constexpr std::initializer_list<absl::string_view> kViewfinderWidgets = {
    "viewfinder", "eosviewfinder"};
// The exposure program (mode dial): P, A, S, M, ...
inline constexpr std::initializer_list<absl::string_view> kModeWidgets = {
    "autoexposuremode", "autoexposuremodedial", "expprogram"};

// The widget called `name`, or nullptr.
const ConfigWidget* FindWidget(const std::vector<ConfigWidget>& widgets,
                               absl::string_view name);
// The first of `names` the camera has, or nullptr.
const ConfigWidget* FindWidget(const std::vector<ConfigWidget>& widgets,
                               std::initializer_list<absl::string_view> names);
// The shutter-speed widget: the first of kShutterWidgets with at least one
// timed choice, or nullptr.
const ConfigWidget* FindShutterWidget(const std::vector<ConfigWidget>& widgets);

// The settings the tree's current values stand for: exposure_s 0 for bulb
// or unknown, iso 0 for auto, aperture_f 0 when unknown, format nullopt
// when the camera has no format widget or its value is not a known format.
hardware::ExposureSettings ReadExposureSettings(
    const std::vector<ConfigWidget>& widgets);

// "(iso, isospeed)" for messages.
std::string WidgetNames(std::initializer_list<absl::string_view> names);

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_WIDGETS_H_
