// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/rig_calibration.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "daemon/store/calibration_repository.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "proto/hdrstereo/v1/capture_defaults.h"

namespace hdrstereo::jobs {
namespace {

std::string JoinPx(const std::vector<double>& values) {
  return absl::StrJoin(values, " ", [](std::string* out, double v) {
    absl::StrAppendFormat(out, "%.3f", v);
  });
}

}  // namespace

calib::BoardSpec BoardOf(const v1::CalibrationPlan& plan) {
  // 0 is the default here too: a plan stored before the board was named
  // (a calibration resumed after an upgrade) is not normalized again.
  auto or_default = [](auto value, auto fallback) {
    return value > 0 ? value : fallback;
  };
  calib::BoardSpec board;
  board.inner_corners =
      cv::Size(or_default(plan.board_columns(), v1::kDefaultBoardColumns),
               or_default(plan.board_rows(), v1::kDefaultBoardRows));
  board.square_m =
      or_default(plan.board_square_mm(), v1::kDefaultBoardSquareMm) / 1000;
  return board;
}

std::string BoardMissing(const hardware::Frame& frame,
                         const calib::BoardSpec& board) {
  if (frame.format == hardware::ImageFormat::kRaw) return "";
  const cv::Mat image =
      cv::imdecode(cv::Mat(1, static_cast<int>(frame.bytes.size()), CV_8UC1,
                           const_cast<char*>(frame.bytes.data())),
                   cv::IMREAD_GRAYSCALE);
  if (image.empty()) return "";  // PersistFrame says it is corrupt
  absl::StatusOr<std::vector<cv::Point2f>> corners =
      calib::FindChessboard(image, board.inner_corners, "the frame");
  return corners.ok() ? "" : std::string(corners.status().message());
}

absl::Status CalibrateRig(JobContext& context, store::FrameRepository& frames,
                          const store::CaptureRecord& capture,
                          const std::filesystem::path& session_dir, int poses,
                          const calib::BoardSpec& board) {
  if (poses < 3) {
    context.Warn(absl::StrCat("the rig is not calibrated: ", poses,
                              " pose(s), a calibration needs at least 3"));
    return absl::OkStatus();
  }
  ASSIGN_OR_RETURN(std::vector<store::FrameRecord> recorded,
                   frames.FramesOfCapture(capture.id));
  std::sort(recorded.begin(), recorded.end(),
            [](const store::FrameRecord& a, const store::FrameRecord& b) {
              return a.sequence < b.sequence;
            });
  std::vector<std::vector<cv::Point2f>> corners[2];
  cv::Size size;
  for (const store::FrameRecord& frame : recorded) {
    const cv::Mat image =
        cv::imread((session_dir / frame.path).string(), cv::IMREAD_GRAYSCALE);
    if (image.empty()) {
      context.Warn(absl::StrCat("the rig is not calibrated: ", frame.path,
                                " cannot be read here (RAW?); run "
                                "`hdrstereo-proc calibrate` on the frames"));
      return absl::OkStatus();
    }
    size = image.size();
    ASSIGN_OR_RETURN(
        std::vector<cv::Point2f> found,
        calib::FindChessboard(image, board.inner_corners, frame.path));
    corners[frame.view_index == 0 ? 0 : 1].push_back(std::move(found));
  }
  ASSIGN_OR_RETURN(
      const calib::StereoCalibration calibration,
      calib::CalibrateStereo(corners[0], corners[1], size, {.board = board}));
  ASSIGN_OR_RETURN(
      const calib::CalibrationQuality quality,
      calib::AssessCalibration(calibration, corners[0], corners[1]));
  const std::string dir = absl::StrCat("rig/calibrations/", capture.id);
  const std::filesystem::path abs = context.store().files().root() / dir;
  std::error_code ec;
  std::filesystem::create_directories(abs, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot create ", abs.string(), ": ", ec.message()));
  }
  RETURN_IF_ERROR(calib::SaveCalibration(abs / "calibration.yml", calibration));
  for (int v = 0; v < 2; ++v) {
    std::vector<uchar> png;
    cv::imencode(".png",
                 v == 0 ? quality.coverage_left : quality.coverage_right, png);
    RETURN_IF_ERROR(io::WriteFileAtomically(
        abs / (v == 0 ? "coverage-left.png" : "coverage-right.png"),
        std::string(png.begin(), png.end())));
  }
  store::CalibrationRecord record;
  record.capture_id = capture.id;
  record.job_id = context.job().id;
  record.dir = dir;
  record.poses = static_cast<int>(corners[0].size());
  record.rms_stereo = calibration.rms_stereo;
  record.rms_left = quality.rms_left;
  record.rms_right = quality.rms_right;
  record.coverage_left = quality.coverage_fraction_left;
  record.coverage_right = quality.coverage_fraction_right;
  ASSIGN_OR_RETURN(
      const int64_t id,
      store::CalibrationRepository(context.store()).Insert(record));
  context.Info(absl::StrFormat(
      "calibrated the rig (calibration %d, %s): %d poses, stereo rms %.3f px; "
      "per pose rms left %s px, right %s px; the boards cover %.0f%% of the "
      "left view and %.0f%% of the right",
      id, dir, record.poses, calibration.rms_stereo, JoinPx(quality.rms_left),
      JoinPx(quality.rms_right), 100 * quality.coverage_fraction_left,
      100 * quality.coverage_fraction_right));
  return absl::OkStatus();
}

}  // namespace hdrstereo::jobs
