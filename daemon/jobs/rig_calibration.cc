// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/rig_calibration.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "daemon/store/calibration_repository.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/image.h"
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
  absl::StatusOr<cv::Mat> image =
      io::DecodeWithOpenCv(frame.bytes, cv::IMREAD_GRAYSCALE);
  if (!image.ok()) return "";  // PersistFrame says it is corrupt
  absl::StatusOr<std::vector<cv::Point2f>> corners =
      calib::FindChessboard(*image, board.inner_corners, "the frame");
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

absl::StatusOr<std::vector<cv::Point2f>> CalibrationGuide::CornersOf(
    const store::FrameRecord& frame, const std::filesystem::path& dir,
    const calib::BoardSpec& board) {
  if (auto it = corners_.find(frame.id); it != corners_.end()) {
    return it->second;
  }
  // A frame read here for the first time: found on a copy at most
  // kGuideWidth wide (quick on a camera's full frame, and finer than live
  // view). None for a frame that cannot be read here (RAW).
  constexpr int kGuideWidth = 1200;
  std::vector<cv::Point2f> corners;
  cv::Mat image = cv::imread((dir / frame.path).string(), cv::IMREAD_GRAYSCALE);
  if (!image.empty()) {
    if (image.cols > kGuideWidth) {
      const double scale = static_cast<double>(kGuideWidth) / image.cols;
      cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_AREA);
    }
    absl::StatusOr<std::vector<cv::Point2f>> found =
        calib::FindChessboard(image, board.inner_corners, frame.path);
    if (found.ok()) {
      for (const cv::Point2f& p : *found) {
        corners.emplace_back((p.x + 0.5f) / image.cols,
                             (p.y + 0.5f) / image.rows);
      }
    }
  }
  corners_[frame.id] = corners;
  return corners;
}

absl::StatusOr<std::optional<PoseGuide>> CalibrationGuide::Guide(
    const store::JobRecord& job, const cv::Mat& preview) {
  v1::CapturePlan plan;
  if (!plan.ParseFromString(job.request)) {
    return absl::DataLossError("the job's capture plan cannot be read");
  }
  if (!plan.has_calibration()) return std::nullopt;
  if (preview.empty()) {
    return absl::InvalidArgumentError("the live-view frame is empty");
  }
  const calib::BoardSpec board = BoardOf(plan.calibration());
  ASSIGN_OR_RETURN(const std::vector<store::FrameRecord> kept,
                   store::FrameRepository(store_).FramesOfJob(job.id));
  const std::filesystem::path dir = store_.files().SessionDir(job.session);
  const cv::Size size = preview.size();
  // The kept poses' corners, per view, in live-view pixels.
  std::vector<std::vector<cv::Point2f>> views[2];
  {
    absl::MutexLock lock(&mutex_);
    if (job_id_ != job.id) {
      corners_.clear();
      job_id_ = job.id;
    }
    for (const store::FrameRecord& frame : kept) {
      ASSIGN_OR_RETURN(std::vector<cv::Point2f> corners,
                       CornersOf(frame, dir, board));
      for (cv::Point2f& p : corners) {
        p = cv::Point2f(p.x * size.width - 0.5f, p.y * size.height - 0.5f);
      }
      views[frame.view_index == 0 ? 0 : 1].push_back(std::move(corners));
    }
  }
  auto covered = [&](const std::vector<std::vector<cv::Point2f>>& poses) {
    return static_cast<double>(
               cv::countNonZero(calib::CoverageMask(poses, size))) /
           size.area();
  };
  PoseGuide guide;
  guide.job_id = job.id;
  guide.poses = plan.calibration().poses();
  // A pose is kept whole (both views) or not at all.
  guide.poses_kept =
      static_cast<int>(std::min(views[0].size(), views[1].size()));
  guide.pose = guide.poses_kept + 1;
  guide.coverage_left = covered(views[0]);
  guide.coverage_right = covered(views[1]);
  absl::StatusOr<std::vector<cv::Point2f>> found = calib::FindChessboard(
      preview, board.inner_corners, "the live-view frame");
  if (found.ok()) {
    guide.corners = *std::move(found);
    views[0].push_back(guide.corners);
    guide.coverage_with_this_pose = covered(views[0]);
  } else {
    guide.board_missing = std::string(found.status().message());
    guide.coverage_with_this_pose = guide.coverage_left;
  }
  return guide;
}

}  // namespace hdrstereo::jobs
