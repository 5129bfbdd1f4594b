// SPDX-License-Identifier: GPL-3.0-or-later
// Scene files for the simulator (JSON written by people, shared by labs).
#include "hardware/sim/scene.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  absl::StatusOr<hdrstereo::sim::Scene> scene =
      hdrstereo::sim::ParseScene(hdrstereo::fuzz::AsText(data, size));
  if (!scene.ok()) return 0;
  FUZZ_CHECK(scene->camera.width > 0 && scene->camera.height > 0);
  return 0;
}
