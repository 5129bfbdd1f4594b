// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real driver's settings logic against the configuration trees of real
// cameras: every `gphoto2 --list-all-config` dump in
// ../shared/data/gphoto2-config-dumps (libgphoto2's own collection) is
// replayed through ReplayApi, and Gphoto2Camera configures it as it would
// the camera:
//   - each exposure of the capture jobs' default bracket (the thesis' 8,
//     1/15 .. 1/2000 s) maps to the nearest timed shutter choice in stops,
//     within 1/3 stop wherever the camera offers such a choice; bulb, auto
//     and the cameras' special codes are never chosen;
//   - ISO and aperture choices parse, and setting one takes that choice;
//   - what cannot be supported fails with a message naming the widget.
// One ctest per dump; the summary test counts the fully supported ones.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "hardware/gphoto2/config_dump.h"
#include "hardware/gphoto2/gphoto2_camera.h"
#include "hardware/gphoto2/replay_api.h"
#include "hardware/gphoto2/settings.h"
#include "hardware/gphoto2/widgets.h"
#include "proto/hdrstereo/v1/capture_defaults.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::gphoto2 {
namespace {

// The settings to configure (format left as is).
hardware::ExposureSettings Exposure(double seconds, int iso = 0,
                                    double aperture_f = 0) {
  hardware::ExposureSettings s;
  s.exposure_s = seconds;
  s.iso = iso;
  s.aperture_f = aperture_f;
  return s;
}

using ::testing::AnyOf;
using ::testing::HasSubstr;

constexpr double kThirdStop = 1.0 / 3 + 1e-6;
// The parameter that stands in for the dumps when the data folder is absent.
constexpr char kNoDumps[] = "no_dumps";

std::filesystem::path DumpDir() {
  return std::filesystem::path(HDRSTEREO_SHARED_DIR) / "data" /
         "gphoto2-config-dumps" / "cameras";
}

// The dump files holding a config tree (a line starting "/main/").
std::vector<std::string> DumpsWithTree() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(DumpDir(), ec)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    const std::string text = bytes.str();
    if (absl::StartsWith(text, "/main/") ||
        absl::StrContains(text, "\n/main/")) {
      names.push_back(entry.path().filename().string());
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

double Stops(double a, double b) { return std::abs(std::log2(a / b)); }

// What one dump supports, found by driving the real driver over its replay.
struct DumpReport {
  std::string file;
  std::string model;
  std::string shutter_widget;  // empty: none with timed choices
  double worst_stops = 0;      // over the bracket
  bool shutter_ok = false;     // every exposure within 1/3 stop
  bool iso_ok = false;
  bool aperture_ok = false;
  std::vector<std::string> problems;  // why not fully supported

  bool Full() const { return shutter_ok && iso_ok && aperture_ok; }
};

// Evaluates `file`; every check that must hold for any camera is an
// EXPECT, so the parameterised test fails on it.
DumpReport Evaluate(const std::string& file) {
  DumpReport report;
  report.file = file;
  absl::StatusOr<CameraDump> dump = LoadCameraDump(DumpDir() / file);
  std::ifstream in(DumpDir() / file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  // A tree: some /main/ path with a Type line among the next four lines
  // (Label, maybe Readonly, maybe a blank line come first).
  bool has_types = false;
  const std::vector<std::string> lines = absl::StrSplit(bytes.str(), '\n');
  for (size_t i = 0; i < lines.size() && !has_types; ++i) {
    if (!absl::StartsWith(lines[i], "/main/")) continue;
    for (size_t k = i + 1; k < std::min(lines.size(), i + 5); ++k) {
      const absl::string_view field = absl::StripAsciiWhitespace(lines[k]);
      if (absl::StartsWith(field, "Type: ")) has_types = true;
      if (!field.empty() && !absl::StartsWith(field, "Label:") &&
          !absl::StartsWith(field, "Readonly:")) {
        break;
      }
    }
  }
  if (!has_types) {
    // `gphoto2 --list-config` (paths only): nothing to replay, and it says so.
    EXPECT_THAT(dump, testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("only paths")));
    report.problems.push_back("a --list-config listing: paths, no values");
    return report;
  }
  EXPECT_THAT(dump, testing::IsOk());
  if (!dump.ok()) {
    report.problems.push_back(std::string(dump.status().message()));
    return report;
  }
  report.model = dump->model;
  const std::vector<ConfigWidget> widgets = dump->widgets;
  auto api = std::make_unique<ReplayApi>(*dump);
  ReplayApi* replay = api.get();
  Gphoto2Options options;
  options.call_timeout = absl::Seconds(5);
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      Gphoto2Camera::OpenWithApi(options, std::move(api));
  EXPECT_THAT(camera, testing::IsOk());
  if (!camera.ok()) {
    report.problems.push_back(std::string(camera.status().message()));
    return report;
  }
  auto current = [&](const std::string& name) {
    std::vector<ConfigWidget> now;
    replay->GetConfig(&now);
    const ConfigWidget* w = FindWidget(now, name);
    return w == nullptr ? std::string("(missing)") : w->value;
  };

  // Shutter speed: the bracket.
  const ConfigWidget* shutter = FindShutterWidget(widgets);
  // An exposure the camera offers, for setting ISO and aperture.
  double offered = 0;
  if (shutter != nullptr) {
    offered = ParseShutterSpeed(shutter->value)
                  .value_or(TimedShutterChoices(shutter->choices)[0].seconds);
  }
  if (shutter == nullptr) {
    absl::StatusOr<hardware::ExposureSettings> applied =
        (*camera)->Configure(Exposure(1.0 / 125));
    EXPECT_THAT(applied,
                testing::StatusIs(absl::StatusCode::kFailedPrecondition,
                                  HasSubstr("shutterspeed")));
    report.problems.push_back(std::string(applied.status().message()));
  } else if (shutter->read_only) {
    // Recorded with the mode dial off M: the driver says so, by name.
    const double other = offered < 0.01 ? offered * 4 : offered / 4;
    // (A single recorded choice fails the range check first.)
    EXPECT_THAT((*camera)->Configure(Exposure(other)),
                AnyOf(testing::StatusIs(absl::StatusCode::kFailedPrecondition,
                                        HasSubstr(absl::StrCat(
                                            shutter->name, " is read-only"))),
                      testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr(shutter->path))));
    report.problems.push_back(
        absl::StrCat(shutter->path, " is read-only in this dump"));
  } else {
    report.shutter_widget = shutter->name;
    const std::vector<ShutterChoice> timed =
        TimedShutterChoices(shutter->choices);
    report.shutter_ok = true;
    for (double t : v1::kDefaultStereoExposuresS) {
      SCOPED_TRACE(FormatSeconds(t));
      double best = std::numeric_limits<double>::infinity();
      for (const ShutterChoice& c : timed)
        best = std::min(best, Stops(c.seconds, t));
      absl::StatusOr<hardware::ExposureSettings> applied =
          (*camera)->Configure(Exposure(t));
      if (best > kThirdStop) {
        // Nothing within 1/3 stop: the camera's range or steps end here.
        report.shutter_ok = false;
        report.problems.push_back(
            absl::StrCat(shutter->name, " has no choice within 1/3 stop of ",
                         FormatSeconds(t), " (nearest ",
                         absl::StrFormat("%.2f", best), " stop)"));
        if (!applied.ok()) {
          EXPECT_THAT(applied,
                      testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr(shutter->name)));
        }
        continue;
      }
      EXPECT_THAT(applied, testing::IsOk());
      if (!applied.ok()) {
        report.shutter_ok = false;
        report.problems.push_back(std::string(applied.status().message()));
        continue;
      }
      const std::string chosen = current(shutter->name);
      EXPECT_THAT(shutter->choices, ::testing::Contains(chosen));
      EXPECT_FALSE(IsBulb(chosen)) << chosen;
      std::optional<double> seconds = ParseShutterSpeed(chosen);
      if (!seconds.has_value()) {
        ADD_FAILURE() << chosen << " is not a timed choice";
        continue;
      }
      EXPECT_DOUBLE_EQ(applied->exposure_s, *seconds);
      const double error = Stops(*seconds, t);
      EXPECT_LE(error, best + 1e-9) << chosen << " is not the nearest choice";
      EXPECT_LE(error, kThirdStop) << chosen;
      report.worst_stops = std::max(report.worst_stops, error);
    }
  }

  // ISO: plain numbers parse as themselves, everything else (Auto,
  // "Unknown value 007b", "100 Multi Frame Noise Reduction") not at all.
  const ConfigWidget* iso = FindWidget(widgets, kIsoWidgets);
  std::vector<int> isos;
  if (iso != nullptr) {
    for (const std::string& choice : iso->choices) {
      std::optional<int> value = ParseIso(choice);
      const std::string trimmed(absl::StripAsciiWhitespace(choice));
      int plain = 0;
      if (absl::SimpleAtoi(trimmed, &plain) && plain > 0) {
        EXPECT_EQ(value, plain) << choice;
      }
      const std::string lower = absl::AsciiStrToLower(choice);
      if (absl::StrContains(lower, "auto") ||
          absl::StrContains(lower, "unknown") ||
          absl::StrContains(lower, "unbekannt") ||
          absl::StrContains(lower, "noise") ||
          absl::StrContains(lower, "rausch")) {
        EXPECT_EQ(value, std::nullopt) << choice;
      }
      if (value.has_value()) isos.push_back(*value);
    }
  }
  if (isos.empty()) {
    report.problems.push_back(
        iso == nullptr ? "no ISO widget"
                       : absl::StrCat(iso->name, " offers no numeric ISO"));
  } else if (iso->read_only) {
    report.problems.push_back(absl::StrCat(iso->path, " is read-only"));
  } else if (shutter != nullptr && !shutter->read_only) {
    const int wanted = std::count(isos.begin(), isos.end(), 100) > 0
                           ? 100
                           : *std::min_element(isos.begin(), isos.end());
    absl::StatusOr<hardware::ExposureSettings> applied =
        (*camera)->Configure(Exposure(offered, wanted));
    EXPECT_THAT(applied, testing::IsOk());
    if (applied.ok()) {
      EXPECT_EQ(applied->iso, wanted);
      EXPECT_EQ(ParseIso(current(iso->name)), wanted);
      report.iso_ok = true;
    } else {
      report.problems.push_back(std::string(applied.status().message()));
    }
  }

  // Aperture: "f/5.6", "5.6", "f/3,5" parse; a range widget is refused
  // with its name.
  const ConfigWidget* aperture = FindWidget(widgets, kApertureWidgets);
  std::vector<double> stops;
  if (aperture != nullptr) {
    for (const std::string& choice : aperture->choices) {
      if (std::optional<double> f = ParseAperture(choice)) stops.push_back(*f);
    }
  }
  if (aperture == nullptr) {
    report.problems.push_back("no aperture widget");
  } else if (aperture->type == WidgetType::kRange) {
    // Sony: a number within the range; the camera takes the nearest stop.
    if (shutter != nullptr && !shutter->read_only && !aperture->read_only) {
      absl::StatusOr<hardware::ExposureSettings> applied =
          (*camera)->Configure(Exposure(offered, 0, 8));
      EXPECT_THAT(applied, testing::IsOk());
      if (applied.ok()) {
        EXPECT_DOUBLE_EQ(applied->aperture_f, 8);
        EXPECT_EQ(current(aperture->name), "8");
        report.aperture_ok = true;
      } else {
        report.problems.push_back(std::string(applied.status().message()));
      }
    } else {
      report.problems.push_back(absl::StrCat(aperture->path, " is read-only"));
    }
  } else if (aperture->choices.empty()) {
    if (shutter != nullptr && !shutter->read_only) {
      EXPECT_THAT((*camera)->Configure(Exposure(offered, 0, 8)),
                  testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                    HasSubstr(aperture->path)));
    }
    report.problems.push_back(absl::StrCat(
        aperture->path, " offers no choice (value \"", aperture->value, "\")"));
  } else if (stops.empty()) {
    report.problems.push_back(
        absl::StrCat(aperture->name, " offers no f-number (",
                     JoinChoices(aperture->choices), ")"));
  } else if (aperture->read_only) {
    report.problems.push_back(absl::StrCat(aperture->path, " is read-only"));
  } else if (shutter != nullptr && !shutter->read_only) {
    const double wanted = stops[stops.size() / 2];
    absl::StatusOr<hardware::ExposureSettings> applied =
        (*camera)->Configure(Exposure(offered, 0, wanted));
    EXPECT_THAT(applied, testing::IsOk());
    if (applied.ok()) {
      EXPECT_NEAR(applied->aperture_f, wanted, 1e-6);
      report.aperture_ok = true;
    } else {
      report.problems.push_back(std::string(applied.status().message()));
    }
  }
  return report;
}

// Live view on the trees of real bodies: a preview sets the body's own
// viewfinder toggle (Canon 5D Mark III "eosviewfinder", Nikon D750
// "viewfinder") as the camera reports live view, and the next capture
// releases it (sets 0) first; a body without one captures as it is.
TEST(CameraDumpLiveViewTest, ACaptureLeavesLiveViewByTheBodysOwnWidget) {
  const std::string kJpeg = "\xff\xd8 frame";
  FrameSource file =
      [&](const hardware::ExposureSettings&) -> absl::StatusOr<ReplayFile> {
    return ReplayFile{.bytes = kJpeg, .extension = "jpg"};
  };
  for (const auto& [name, widget] :
       std::vector<std::pair<std::string, std::string>>{
           {"canon-eos5dmark3.txt", "eosviewfinder"},
           {"nikon-d750.txt", "viewfinder"},
           {"sony-a6400.txt", ""}}) {
    SCOPED_TRACE(name);
    absl::StatusOr<CameraDump> dump = LoadCameraDump(DumpDir() / name);
    if (!dump.ok() && !std::filesystem::exists(DumpDir())) {
      GTEST_SKIP() << "no camera dumps under " << DumpDir();
    }
    ASSERT_THAT(dump, testing::IsOk());
    EXPECT_EQ(FindWidget(dump->widgets, kViewfinderWidgets) != nullptr,
              !widget.empty());
    absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
        Gphoto2Camera::OpenWithApi(
            {}, std::make_unique<ReplayApi>(*dump, file, nullptr, file));
    ASSERT_THAT(camera, testing::IsOk());
    ASSERT_THAT((*camera)->Configure(Exposure(1.0 / 125)).status(),
                testing::IsOk());
    absl::StatusOr<hardware::Frame> preview = (*camera)->Preview();
    ASSERT_THAT(preview, testing::IsOk());
    EXPECT_EQ(preview->bytes, kJpeg);
    auto value = [&]() -> std::string {
      absl::StatusOr<std::vector<ConfigWidget>> widgets = (*camera)->Config();
      const ConfigWidget* found =
          widgets.ok() ? FindWidget(*widgets, widget) : nullptr;
      return found != nullptr ? found->value : "(none)";
    };
    if (!widget.empty()) {
      EXPECT_EQ(value(), "1");
    }
    absl::StatusOr<hardware::Frame> frame = (*camera)->Capture();
    ASSERT_THAT(frame, testing::IsOk());
    if (!widget.empty()) {
      EXPECT_EQ(value(), "0");
    }
  }
}

class CameraDumpTest : public ::testing::TestWithParam<std::string> {};

TEST_P(CameraDumpTest, BracketIsoAndApertureMapOntoTheCamera) {
  if (GetParam() == kNoDumps) {
    GTEST_SKIP() << "no camera dumps with a config tree under " << DumpDir();
  }
  const DumpReport report = Evaluate(GetParam());
  std::cout << absl::StrFormat(
      "%s (%s): %s worst %.3f stop over the bracket; %s\n", report.file,
      report.model,
      report.shutter_widget.empty() ? "no shutter widget,"
                                    : report.shutter_widget + ",",
      report.worst_stops,
      report.Full() ? "fully supported"
                    : absl::StrCat("not fully supported: ",
                                   absl::StrJoin(report.problems, "; ")));
}

std::vector<std::string> DumpParams() {
  std::vector<std::string> names = DumpsWithTree();
  if (names.empty()) names.push_back(kNoDumps);
  return names;
}

std::string ParamName(const ::testing::TestParamInfo<std::string>& info) {
  std::string name;
  for (char c : info.param) {
    name += absl::ascii_isalnum(static_cast<unsigned char>(c)) ? c : '_';
  }
  return name;
}

INSTANTIATE_TEST_SUITE_P(RealDumps, CameraDumpTest,
                         ::testing::ValuesIn(DumpParams()), ParamName);

TEST(CameraDumpSummaryTest, CountsFullySupportedCameras) {
  const std::vector<std::string> names = DumpsWithTree();
  if (names.empty()) {
    GTEST_SKIP() << "no camera dumps under " << DumpDir();
  }
  int full = 0;
  std::vector<std::string> rest;
  for (const std::string& name : names) {
    const DumpReport report = Evaluate(name);
    if (report.Full()) {
      ++full;
    } else {
      rest.push_back(
          absl::StrCat(name, ": ", absl::StrJoin(report.problems, "; ")));
    }
  }
  std::cout << full << " of " << names.size()
            << " dumps with a config tree are fully supported; the rest:\n  "
            << absl::StrJoin(rest, "\n  ") << "\n";
  // Measured: 41 of 192 (see docs/results.md); a reader or mapping that
  // broke would lose many.
  EXPECT_GE(names.size(), 150u);
  EXPECT_GE(full, 38);
}

}  // namespace
}  // namespace hdrstereo::gphoto2
