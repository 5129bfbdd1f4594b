// SPDX-License-Identifier: GPL-3.0-or-later
//
// A session folder rendered by the simulator in the capture layout
// (processing/io/capture_layout.h), for pipeline tests:
//   captures/1/left/ambient/exp_<mid>.png
//   captures/1/<left|right>/stereo/exp_<tag>.png       bracketed stereo
//   captures/1/truth/{disp0.pfm,nonocc0.png,calib.txt,...}  exact truth
//   captures/2/<left|right>/structured_light/sl_<id>_exp_<tag>.png
// The camera is scaled down (f scaled alike) and the projector made small
// to keep tests quick.
#ifndef HDRSTEREO_TESTS_SUPPORT_SIM_SESSION_H_
#define HDRSTEREO_TESTS_SUPPORT_SIM_SESSION_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace hdrstereo::testing {

struct SimSessionOptions {
  std::string scene = "lab-lamp";
  int width = 240;  // camera; the height keeps the aspect ratio
  double baseline_mm = 150;
  std::vector<double> exposures = {1.0 / 15, 1.0 / 60, 1.0 / 250, 1.0 / 1000,
                                   1.0 / 4000};
  bool structured_light = true;
  std::vector<double> sl_exposures = {1.0 / 30, 1.0 / 125};
  int projector_width = 256;
  int projector_height = 192;
  bool truth = true;
};

absl::Status RenderSimSession(const std::filesystem::path& dir,
                              const SimSessionOptions& options = {});

// The default session rendered once per test program into a private
// folder, then copied to `dir` (which must not exist yet or be empty).
absl::Status CopyCachedSimSession(const std::filesystem::path& dir);

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_SIM_SESSION_H_
