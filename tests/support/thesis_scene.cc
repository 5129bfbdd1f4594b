// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/thesis_scene.h"

#include <vector>

#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/truth.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::testing {

absl::StatusOr<experiment::TableInput> RenderThesisScene(
    const std::string& name, int width) {
  ASSIGN_OR_RETURN(sim::Scene scene, sim::LoadScene(name));
  sim::ScaleCamera(scene, width);
  const std::vector<double> times = {1.0 / 15,   1.0 / 30,  1.0 / 60,
                                     1.0 / 125,  1.0 / 250, 1.0 / 500,
                                     1.0 / 1000, 1.0 / 2000};
  sim::SimWorld world(scene);
  experiment::TableInput in;
  in.name = name;
  for (double t : times) {
    world.SetStagePosition(0);
    in.left.images.push_back(world.RenderExposure({t, 100}, 8));
    world.SetStagePosition(150);
    in.right.images.push_back(world.RenderExposure({t, 100}, 8));
  }
  in.left.exposure_s = in.right.exposure_s = times;
  ASSIGN_OR_RETURN(const sim::StereoTruth truth, world.Truth(0, 150));
  in.truth = truth.left.disparity;
  in.nonoccluded = truth.left.nonoccluded;
  in.ldr_index = 4;  // 1/250 s
  return in;
}

}  // namespace hdrstereo::testing
