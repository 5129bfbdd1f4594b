// SPDX-License-Identifier: GPL-3.0-or-later
//
// The fixture of the capture tests (capture_test.cc, device_fault_test.cc,
// suspender_test.cc, disk_guard_test.cc, auto_bracket_test.cc: one
// executable): the real daemon with simulated hardware (the real Zaber
// driver on the emulated controller's pty), real SQLite, real gRPC and the
// real CLI. Scenes are bundled ones (lab-lamp by default) at a small
// resolution so the suite stays quick; what is checked does not depend on
// the size.
#ifndef HDRSTEREO_TESTS_INTEGRATION_CAPTURE_FIXTURE_H_
#define HDRSTEREO_TESTS_INTEGRATION_CAPTURE_FIXTURE_H_

#include <filesystem>
#include <string>

#include "absl/strings/str_cat.h"
#include "nlohmann/json.hpp"
#include "tests/support/daemon_fixture.h"

namespace hdrstereo {

class CaptureTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void StartSim(const nlohmann::json& patch = testing::SmallLabLamp(),
                double time_scale = 0,
                const std::string& bundled = "lab-lamp") {
    scene_path_ = WriteScene(bundled, patch);
    StartDaemon({"--sim-scene", scene_path_.string(), "--sim-time-scale",
                 absl::StrCat(time_scale)});
  }

  std::filesystem::path scene_path_;
};

}  // namespace hdrstereo

#endif  // HDRSTEREO_TESTS_INTEGRATION_CAPTURE_FIXTURE_H_
