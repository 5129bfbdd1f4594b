// SPDX-License-Identifier: GPL-3.0-or-later
//
// Small analytic scenes for the simulator tests: a 160 x 120 camera with
// f = 200 px and cx, cy at the image centre.
#ifndef HDRSTEREO_TESTS_UNIT_SIM_TEST_SCENES_H_
#define HDRSTEREO_TESTS_UNIT_SIM_TEST_SCENES_H_

#include <gtest/gtest.h>

#include <string>

#include "absl/strings/str_cat.h"
#include "hardware/sim/scene.h"

namespace hdrstereo::sim::testing {

inline constexpr double kF = 200.0;
inline constexpr double kCx = 79.5;
inline constexpr double kCy = 59.5;

// `objects` and `extra` are JSON fragments (without the surrounding
// brackets / leading comma).
inline std::string SmallSceneJson(const std::string& objects,
                                  const std::string& extra = "") {
  return absl::StrCat(
      R"({"name": "test", "seed": 5,
          "camera": {"width": 160, "height": 120, "fx": 200, "fy": 200},
          "ambient_lux": 50,
          "objects": [)",
      objects, "]", extra.empty() ? "" : ", ", extra, "}");
}

inline Scene ParseOrDie(const std::string& json) {
  absl::StatusOr<Scene> scene = ParseScene(json);
  EXPECT_TRUE(scene.ok()) << scene.status();
  return scene.ok() ? *scene : Scene();
}

// A bundled scene at 1/4 resolution (300 x 225), to keep tests fast.
inline Scene SmallBundledScene(const std::string& name) {
  absl::StatusOr<Scene> scene = LoadBundledScene(name);
  EXPECT_TRUE(scene.ok()) << scene.status();
  if (!scene.ok()) return Scene();
  ScaleCamera(*scene, scene->camera.width / 4);
  return *scene;
}

}  // namespace hdrstereo::sim::testing

#endif  // HDRSTEREO_TESTS_UNIT_SIM_TEST_SCENES_H_
