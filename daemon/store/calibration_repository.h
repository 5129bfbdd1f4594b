// SPDX-License-Identifier: GPL-3.0-or-later
//
// The rig's calibrations (table `rig_calibrations`): one row per
// calibration capture whose poses were calibrated, with its quality and the
// folder (relative to the data root) that holds its files. Processing uses
// the latest for sessions without a calibration capture of their own.
#ifndef HDRSTEREO_DAEMON_STORE_CALIBRATION_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_CALIBRATION_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct CalibrationRecord {
  int64_t id = 0;
  int64_t capture_id = 0;
  std::string session;  // of the calibration capture
  int64_t job_id = 0;
  // Folder relative to the data root: calibration.yml (calib::
  // SaveCalibration), coverage-left.png, coverage-right.png.
  std::string dir;
  int poses = 0;
  double rms_stereo = 0;                         // px
  std::vector<double> rms_left, rms_right;       // px, per pose
  double coverage_left = 0, coverage_right = 0;  // fraction of the image
  int64_t create_time_ms = 0;
};

class CalibrationRepository {
 public:
  explicit CalibrationRepository(Store& store) : store_(store) {}

  // Records a calibration (create_time_ms now); returns its id.
  absl::StatusOr<int64_t> Insert(const CalibrationRecord& record);
  // The latest calibration of the rig, or nullopt when there is none.
  absl::StatusOr<std::optional<CalibrationRecord>> Latest();

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_CALIBRATION_REPOSITORY_H_
