// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/gphoto2/widgets.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "hardware/gphoto2/settings.h"

namespace hdrstereo::gphoto2 {

const ConfigWidget* FindWidget(const std::vector<ConfigWidget>& widgets,
                               absl::string_view name) {
  for (const ConfigWidget& widget : widgets) {
    if (widget.name == name) return &widget;
  }
  return nullptr;
}

const ConfigWidget* FindWidget(const std::vector<ConfigWidget>& widgets,
                               std::initializer_list<absl::string_view> names) {
  for (absl::string_view name : names) {
    if (const ConfigWidget* widget = FindWidget(widgets, name)) return widget;
  }
  return nullptr;
}

const ConfigWidget* FindShutterWidget(
    const std::vector<ConfigWidget>& widgets) {
  for (absl::string_view name : kShutterWidgets) {
    const ConfigWidget* widget = FindWidget(widgets, name);
    if (widget != nullptr && !TimedShutterChoices(widget->choices).empty()) {
      return widget;
    }
  }
  return nullptr;
}

hardware::ExposureSettings ReadExposureSettings(
    const std::vector<ConfigWidget>& widgets) {
  hardware::ExposureSettings settings;
  if (const ConfigWidget* shutter = FindShutterWidget(widgets)) {
    settings.exposure_s = ParseShutterSpeed(shutter->value).value_or(0);
  }
  if (const ConfigWidget* iso = FindWidget(widgets, kIsoWidgets)) {
    settings.iso = ParseIso(iso->value).value_or(0);
  }
  if (const ConfigWidget* aperture = FindWidget(widgets, kApertureWidgets)) {
    settings.aperture_f = ParseAperture(aperture->value).value_or(0);
  }
  if (const ConfigWidget* format = FindWidget(widgets, kFormatWidgets)) {
    settings.format = ClassifyFormatChoice(format->value);
  }
  return settings;
}

std::string WidgetNames(std::initializer_list<absl::string_view> names) {
  return absl::StrCat("(", absl::StrJoin(names, ", "), ")");
}

}  // namespace hdrstereo::gphoto2
