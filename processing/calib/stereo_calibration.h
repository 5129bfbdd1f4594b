// SPDX-License-Identifier: GPL-3.0-or-later
//
// Chessboard stereo calibration of a one-camera stage rig: the left and right
// views are taken by the same camera moved along the stage, so both share one
// set of intrinsics. Rectification (OpenCV calib3d, Bouguet) makes epipolar
// lines horizontal; it is applied to every exposure of both views before
// merging (thesis ch. 3).
#ifndef HDRSTEREO_PROCESSING_CALIB_STEREO_CALIBRATION_H_
#define HDRSTEREO_PROCESSING_CALIB_STEREO_CALIBRATION_H_

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::calib {

struct BoardSpec {
  cv::Size inner_corners{9, 6};  // corners per row, per column
  double square_m = 0.025;       // edge of one square in metres
};

// Finds the inner corners (sub-pixel refined) of a chessboard in an 8/16-bit
// or float image, grey or colour. `name` is used in the error when the board
// is not found.
absl::StatusOr<std::vector<cv::Point2f>> FindChessboard(const cv::Mat& image,
                                                        cv::Size inner_corners,
                                                        absl::string_view name);

struct StereoCalibration {
  cv::Size image_size;
  cv::Mat camera_matrix;  // 3x3 CV_64F, shared by both views
  cv::Mat dist_coeffs;    // 1x5 CV_64F (k1 k2 p1 p2 k3), shared
  cv::Mat rotation;       // 3x3: right camera = rotation * left + translation
  cv::Mat translation;    // 3x1, metres
  double rms_intrinsics = 0;  // reprojection RMS (px) of the shared fit
  double rms_stereo = 0;      // of the stereo fit
  // Rectification (cv::stereoRectify with CALIB_ZERO_DISPARITY).
  cv::Mat r1, r2, p1, p2, q;
};

struct CalibrationOptions {
  BoardSpec board;
  // cv::stereoRectify's alpha: -1 keeps the focal length (an ideal rig then
  // gets identity maps), 0 crops to valid pixels, 1 keeps all pixels.
  double alpha = -1;
  bool fix_k3 = true;  // estimate k1, k2, p1, p2 only
  // Assume a distortion-free lens (all coefficients fixed at 0); use when
  // the boards cannot cover the image corners.
  bool zero_distortion = false;
};

// Calibrates from corner lists: left[i] and right[i] are the same board pose
// seen from the two views. At least 3 pairs.
absl::StatusOr<StereoCalibration> CalibrateStereo(
    const std::vector<std::vector<cv::Point2f>>& left,
    const std::vector<std::vector<cv::Point2f>>& right, cv::Size image_size,
    const CalibrationOptions& options = {});

// Detects the board in every pair of images and calibrates. `left_names` and
// `right_names` (same length as the images) name files in errors: a board
// not found is an error naming the file.
absl::StatusOr<StereoCalibration> CalibrateStereoFromImages(
    const std::vector<cv::Mat>& left, const std::vector<cv::Mat>& right,
    const std::vector<std::string>& left_names,
    const std::vector<std::string>& right_names,
    const CalibrationOptions& options = {});

// How good a calibration is, from the corner lists it was made from.
struct CalibrationQuality {
  // Reprojection RMS (px) of each pose's corners, per view: the board's
  // pose fitted (solvePnP) with the calibration's intrinsics.
  std::vector<double> rms_left, rms_right;
  // 255 where some pose's board (the hull of its corners) covered the
  // image, per view, and the covered fraction of the image.
  cv::Mat coverage_left, coverage_right;  // CV_8UC1, image_size
  double coverage_fraction_left = 0, coverage_fraction_right = 0;
};

absl::StatusOr<CalibrationQuality> AssessCalibration(
    const StereoCalibration& calibration,
    const std::vector<std::vector<cv::Point2f>>& left,
    const std::vector<std::vector<cv::Point2f>>& right,
    const BoardSpec& board = {});

// The area (a fraction of the image) the boards' corner hulls cover so far:
// what live view shows while the operator places poses.
cv::Mat CoverageMask(const std::vector<std::vector<cv::Point2f>>& corners,
                     cv::Size image_size);

enum class View { kLeft, kRight };

// Per-view remap tables (CV_32FC1): rectified(x, y) = image(map_x, map_y).
struct RectificationMaps {
  cv::Size image_size;
  cv::Mat left_x, left_y, right_x, right_y;
};

absl::StatusOr<RectificationMaps> ComputeRectificationMaps(
    const StereoCalibration& calibration);

// Rectifies one image (any depth/channels; bilinear) of the given view.
absl::StatusOr<cv::Mat> Rectify(const cv::Mat& image,
                                const RectificationMaps& maps, View view);

// Rectified positions of points of one view (e.g. chessboard corners).
absl::StatusOr<std::vector<cv::Point2f>> RectifyPoints(
    const std::vector<cv::Point2f>& points,
    const StereoCalibration& calibration, View view);

// Saves/loads the rig calibration and its rectification (OpenCV FileStorage
// YAML, written atomically). The maps are recomputed from it on load.
absl::Status SaveCalibration(const std::filesystem::path& path,
                             const StereoCalibration& calibration);
absl::StatusOr<StereoCalibration> LoadCalibration(
    const std::filesystem::path& path);

}  // namespace hdrstereo::calib

#endif  // HDRSTEREO_PROCESSING_CALIB_STEREO_CALIBRATION_H_
