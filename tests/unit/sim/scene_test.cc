// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "tests/support/status_matchers.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::hdrstereo::sim::testing::SmallSceneJson;
using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(SceneTest, BundledScenesLoad) {
  const std::vector<std::string> names = BundledSceneNames();
  ASSERT_EQ(names.size(), 6u);
  for (const std::string& name : names) {
    absl::StatusOr<Scene> scene = LoadBundledScene(name);
    ASSERT_TRUE(scene.ok()) << name << ": " << scene.status();
    EXPECT_EQ(scene->name, name);
    EXPECT_FALSE(scene->objects.empty()) << name;
  }
  absl::StatusOr<Scene> lab = LoadBundledScene("lab-lamp");
  ASSERT_TRUE(lab.ok());
  EXPECT_GE(lab->FindObject("lamp"), 0);
  EXPECT_TRUE(lab->projector.present);
  EXPECT_EQ(lab->projector.width, 1024);
  EXPECT_EQ(lab->camera.width, 1200);
  EXPECT_DOUBLE_EQ(lab->rig.travel_mm, 150.0);
  absl::StatusOr<Scene> shadowed = LoadBundledScene("shadowed");
  ASSERT_TRUE(shadowed.ok());
  EXPECT_TRUE(shadowed->projector.present);
}

TEST(SceneTest, UnknownBundledSceneIsNotFound) {
  absl::StatusOr<Scene> scene = LoadBundledScene("no-such-scene");
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(scene.status().message().find("lab-lamp"), std::string::npos);
}

void ExpectErrorNames(const std::string& json, const std::string& field) {
  absl::StatusOr<Scene> scene = ParseScene(json);
  ASSERT_FALSE(scene.ok()) << "accepted: " << json;
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(scene.status().message().find(field), std::string::npos)
      << "wanted \"" << field << "\" in: " << scene.status().message();
}

TEST(SceneTest, ErrorsNameTheBadField) {
  ExpectErrorNames("{not json", "not valid JSON");
  ExpectErrorNames(SmallSceneJson(R"({"type": "plane", "center_mm": [0, 0],
                                      "normal": [0, 0, -1]})"),
                   "objects[0].center_mm");
  ExpectErrorNames(SmallSceneJson(R"({"type": "plane", "center_mm": [0,0,1],
                                      "normal": [0, 0, -1]},
                                     {"type": "cone", "center_mm": [0,0,1]})"),
                   "objects[1].type");
  ExpectErrorNames(SmallSceneJson(R"({"type": "sphere", "center_mm": [0,0,1000],
                         "radius_mm": 10,
                         "material": {"albedo": [0.5, 1.5, 0.5]}})"),
                   "objects[0].material.albedo");
  ExpectErrorNames(SmallSceneJson(R"({"type": "sphere", "center_mm": [0,0,1000],
                         "radius_mm": -1})"),
                   "objects[0].radius_mm");
  ExpectErrorNames(SmallSceneJson(R"({"type": "box", "center_mm": [0,0,1],
                                      "size_mm": [1, 1, 1], "colour": 1})"),
                   "objects[0]: unknown field \"colour\"");
  ExpectErrorNames(SmallSceneJson("", R"("camera": {"width": "wide"})"),
                   "camera.width");
  ExpectErrorNames(SmallSceneJson("", R"("projector": {"gamma": 0})"),
                   "projector.gamma");
  ExpectErrorNames(
      SmallSceneJson("", R"("faults": {"stage": {"stall": {"calls": [0]}}})"),
      "faults.stage.stall.calls[0]");
  ExpectErrorNames(
      SmallSceneJson(
          "", R"("faults": {"camera": {"disconnect_failed_reopens": -2}})"),
      "faults.camera.disconnect_failed_reopens");
  ExpectErrorNames(
      SmallSceneJson(
          R"({"type": "plane", "center_mm": [0,0,1], "normal": [0,0,0]})"),
      "objects[0].normal");
  ExpectErrorNames(SmallSceneJson("", R"("sensor": {"response":
                                          {"kind": "log"}})"),
                   "sensor.response.kind");
}

// The projector's timing: each field is read, has its default
// when absent, and a bad value is refused naming the field.
TEST(SceneTest, ProjectorLatencyAndRefreshRateAreReadAndChecked) {
  const Scene scene = testing::ParseOrDie(SmallSceneJson(
      "", R"("projector": {"latency_s": 0.125, "refresh_hz": 59.94})"));
  EXPECT_DOUBLE_EQ(scene.projector.latency_s, 0.125);
  EXPECT_DOUBLE_EQ(scene.projector.refresh_hz, 59.94);
  const Scene defaults =
      testing::ParseOrDie(SmallSceneJson("", R"("projector": {})"));
  EXPECT_DOUBLE_EQ(defaults.projector.latency_s, 0.0);
  EXPECT_DOUBLE_EQ(defaults.projector.refresh_hz, 60.0);

  EXPECT_THAT(
      ParseScene(SmallSceneJson("", R"("projector": {"latency_s": -0.1})")),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("projector.latency_s: must be in [0, 10], got -0.1")));
  EXPECT_THAT(
      ParseScene(SmallSceneJson("", R"("projector": {"latency_s": "slow"})")),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("projector.latency_s: expected a number")));
  EXPECT_THAT(
      ParseScene(SmallSceneJson("", R"("projector": {"refresh_hz": 0})")),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("projector.refresh_hz: must be in [1, 1000], got 0")));
  EXPECT_THAT(
      ParseScene(SmallSceneJson("", R"("projector": {"refresh_hz": [60]})")),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("projector.refresh_hz: expected a number")));
}

// The faults that come and go (FaultWindow): each field is read, and a bad
// value is refused naming its field.
TEST(SceneTest, FaultWindowsAreReadAndTheirErrorsNameTheField) {
  const Scene scene = testing::ParseOrDie(SmallSceneJson("", R"("faults": {
      "camera": {"low_battery": {"calls": [7], "lasts": 4, "percent": 12}},
      "stage": {"warning_window": {"probability": 0.5, "lasts": 9,
                                   "flag": "WV"}},
      "projector": {"lost": {"calls": [3, 30], "lasts": 6}}})"));
  EXPECT_THAT(scene.camera_faults.low_battery.begins.calls, ElementsAre(7));
  EXPECT_EQ(scene.camera_faults.low_battery.lasts, 4);
  EXPECT_EQ(scene.camera_faults.low_battery_percent, 12);
  EXPECT_DOUBLE_EQ(scene.stage_faults.warning_window.begins.probability, 0.5);
  EXPECT_EQ(scene.stage_faults.warning_window.lasts, 9);
  EXPECT_EQ(scene.stage_faults.warning_window_flag, "WV");
  EXPECT_THAT(scene.projector_faults.lost.begins.calls, ElementsAre(3, 30));
  EXPECT_EQ(scene.projector_faults.lost.lasts, 6);
  // Defaults: one call long, 5 %, "WH".
  const Scene defaults = testing::ParseOrDie(SmallSceneJson("", R"("faults": {
      "camera": {"low_battery": {"calls": [1]}},
      "stage": {"warning_window": {"calls": [1]}}})"));
  EXPECT_EQ(defaults.camera_faults.low_battery.lasts, 1);
  EXPECT_EQ(defaults.camera_faults.low_battery_percent, 5);
  EXPECT_EQ(defaults.stage_faults.warning_window_flag, "WH");
  EXPECT_TRUE(defaults.projector_faults.lost.begins.calls.empty());

  const std::pair<const char*, const char*> bad[] = {
      {R"("camera": {"low_battery": {"calls": [0]}})",
       "faults.camera.low_battery.calls[0]: 0 is outside [1, 1000000000]"},
      {R"("camera": {"low_battery": {"lasts": 0}})",
       "faults.camera.low_battery.lasts: 0 is outside [1, 1000000]"},
      {R"("camera": {"low_battery": {"percent": 101}})",
       "faults.camera.low_battery.percent: 101 is outside [0, 100]"},
      {R"("camera": {"low_battery": {"level": 3}})",
       "faults.camera.low_battery: unknown field \"level\""},
      {R"("stage": {"warning_window": {"flag": "--"}})",
       "faults.stage.warning_window.flag: expected two capital letters"},
      {R"("stage": {"warning_window": {"lasts": 1.5}})",
       "faults.stage.warning_window.lasts: expected an integer"},
      {R"("stage": {"warning_window": {"probability": 2}})",
       "faults.stage.warning_window.probability: must be in [0, 1], got 2"},
      {R"("projector": {"lost": {"lasts": -3}})",
       "faults.projector.lost.lasts: -3 is outside [1, 1000000]"},
      {R"("projector": {"lost": {"percent": 3}})",
       "faults.projector.lost: unknown field \"percent\""},
      {R"("projector": {"gone": {}})",
       "faults.projector: unknown field \"gone\""},
  };
  for (const auto& [faults, message] : bad) {
    EXPECT_THAT(
        ParseScene(
            SmallSceneJson("", absl::StrCat(R"("faults": {)", faults, "}"))),
        StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
        << faults;
  }
}

TEST(SceneTest, DefaultsAndDerivedValues) {
  Scene s = testing::ParseOrDie(SmallSceneJson(
      R"({"name": "wall", "type": "plane", "center_mm": [0, 0, 1000],
          "normal": [0, 0, -2]},
         {"name": "lamp", "type": "sphere", "center_mm": [0, 0, 900],
          "radius_mm": 5, "material": {"emission": 100}})"));
  EXPECT_DOUBLE_EQ(s.camera.cx, 79.5);
  EXPECT_DOUBLE_EQ(s.camera.cy, 59.5);
  EXPECT_DOUBLE_EQ(s.objects[0].normal[2], -1.0);  // normalised
  EXPECT_TRUE(s.objects[0].casts_shadow);
  EXPECT_FALSE(s.objects[1].casts_shadow);  // emitters cast no shadow
  EXPECT_FALSE(s.projector.present);
  EXPECT_TRUE(s.rig.IsIdeal());
}

TEST(SceneTest, ResponseCurveIsMonotonicSShapedAndInvertible) {
  ResponseCurve r;  // default s_curve
  EXPECT_EQ(r.Evaluate(0.0), 0.0);
  EXPECT_EQ(r.Evaluate(1.0), 1.0);
  double prev = -1, max_gamma_gap = 0;
  for (int i = 0; i <= 1000; ++i) {
    const double x = i / 1000.0;
    const double y = r.Evaluate(x);
    EXPECT_GT(y, prev) << "x=" << x;
    prev = y;
    max_gamma_gap = std::max(max_gamma_gap, std::abs(y - std::pow(x, 1 / 2.2)));
    if (i > 0 && i < 1000) {
      EXPECT_NEAR(r.Inverse(y), x, 1e-9);
    }
  }
  // Not a pure gamma curve: it departs from x^(1/2.2) by more than 0.05.
  EXPECT_GT(max_gamma_gap, 0.05);
}

TEST(SceneTest, TimingModelMatchesTrapezoidalProfile) {
  TimingModel t;  // 20 mm/s, 100 mm/s^2
  // Ramps take 0.2 s and 2 mm each; 150 mm: 0.4 s + 146 mm at 20 mm/s.
  EXPECT_NEAR(t.MoveSeconds(150), 0.4 + 146.0 / 20.0, 1e-12);
  // 1 mm never reaches full speed: 2 * sqrt(1 / 100).
  EXPECT_NEAR(t.MoveSeconds(1), 0.2, 1e-12);
  EXPECT_NEAR(t.MoveProgressMm(150, 0.1), 0.5 * 100 * 0.01, 1e-12);
  EXPECT_NEAR(t.MoveProgressMm(150, 1.0), 2.0 + 20 * 0.8, 1e-12);
  EXPECT_DOUBLE_EQ(t.MoveProgressMm(150, 100), 150);
  EXPECT_NEAR(t.CaptureSeconds(1.0 / 15), 1.0 / 15 + 0.75, 1e-12);
}

}  // namespace
}  // namespace hdrstereo::sim
