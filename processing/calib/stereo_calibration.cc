// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/calib/stereo_calibration.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/image.h"

namespace hdrstereo::calib {
namespace {

cv::Mat ToGrey8(const cv::Mat& image) {
  cv::Mat grey = image;
  if (grey.channels() == 3) {
    cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
  } else if (grey.channels() == 4) {
    cv::cvtColor(grey, grey, cv::COLOR_BGRA2GRAY);
  }
  if (grey.depth() == CV_8U) return grey;
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  double lo = 0, hi = 0;
  cv::minMaxLoc(f, &lo, &hi);
  cv::Mat out;
  f.convertTo(out, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0,
              hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
  return out;
}

std::vector<cv::Point3f> BoardPoints(const BoardSpec& board) {
  std::vector<cv::Point3f> pts;
  for (int r = 0; r < board.inner_corners.height; ++r) {
    for (int c = 0; c < board.inner_corners.width; ++c) {
      pts.emplace_back(static_cast<float>(c * board.square_m),
                       static_cast<float>(r * board.square_m), 0.f);
    }
  }
  return pts;
}

}  // namespace

absl::StatusOr<std::vector<cv::Point2f>> FindChessboard(
    const cv::Mat& image, cv::Size inner_corners, absl::string_view name) {
  if (image.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("empty image: ", name));
  }
  std::vector<cv::Point2f> corners;
  try {
    cv::Mat grey = ToGrey8(image);
    bool found = cv::findChessboardCorners(
        grey, inner_corners, corners,
        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found) {
      return absl::NotFoundError(absl::StrCat(
          "chessboard with ", inner_corners.width, "x", inner_corners.height,
          " inner corners not found in ", name));
    }
    cv::cornerSubPix(
        grey, corners, cv::Size(5, 5), cv::Size(-1, -1),
        cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 50,
                         1e-3));
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("chessboard detection failed on ", name, ": ", e.what()));
  }
  return corners;
}

absl::StatusOr<StereoCalibration> CalibrateStereo(
    const std::vector<std::vector<cv::Point2f>>& left,
    const std::vector<std::vector<cv::Point2f>>& right, cv::Size image_size,
    const CalibrationOptions& options) {
  if (left.size() != right.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        left.size(), " left but ", right.size(), " right chessboard views"));
  }
  if (left.size() < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "stereo calibration needs at least 3 board pairs, got ", left.size()));
  }
  const size_t n_corners =
      static_cast<size_t>(options.board.inner_corners.area());
  for (size_t i = 0; i < left.size(); ++i) {
    if (left[i].size() != n_corners || right[i].size() != n_corners) {
      return absl::InvalidArgumentError(
          absl::StrCat("board pair ", i, " has ", left[i].size(), "/",
                       right[i].size(), " corners, expected ", n_corners));
    }
  }
  StereoCalibration out;
  out.image_size = image_size;
  try {
    const std::vector<cv::Point3f> board = BoardPoints(options.board);
    // Shared intrinsics: every view of either side is a view of one camera.
    std::vector<std::vector<cv::Point3f>> object_all;
    std::vector<std::vector<cv::Point2f>> image_all;
    for (size_t i = 0; i < left.size(); ++i) {
      object_all.push_back(board);
      image_all.push_back(left[i]);
      object_all.push_back(board);
      image_all.push_back(right[i]);
    }
    std::vector<cv::Mat> rvecs, tvecs;
    out.camera_matrix = cv::Mat::eye(3, 3, CV_64F);
    out.dist_coeffs = cv::Mat::zeros(1, 5, CV_64F);
    int flags = options.fix_k3 ? cv::CALIB_FIX_K3 : 0;
    if (options.zero_distortion) {
      flags |= cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 |
               cv::CALIB_ZERO_TANGENT_DIST;
    }
    out.rms_intrinsics = cv::calibrateCamera(object_all, image_all, image_size,
                                             out.camera_matrix, out.dist_coeffs,
                                             rvecs, tvecs, flags);
    std::vector<std::vector<cv::Point3f>> object(left.size(), board);
    cv::Mat k2 = out.camera_matrix.clone(), d2 = out.dist_coeffs.clone();
    cv::Mat e, f;
    out.rms_stereo = cv::stereoCalibrate(
        object, left, right, out.camera_matrix, out.dist_coeffs, k2, d2,
        image_size, out.rotation, out.translation, e, f,
        cv::CALIB_FIX_INTRINSIC,
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100,
                         1e-9));
    cv::stereoRectify(out.camera_matrix, out.dist_coeffs, out.camera_matrix,
                      out.dist_coeffs, image_size, out.rotation,
                      out.translation, out.r1, out.r2, out.p1, out.p2, out.q,
                      cv::CALIB_ZERO_DISPARITY, options.alpha);
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("stereo calibration failed: ", e.what()));
  }
  return out;
}

absl::StatusOr<StereoCalibration> CalibrateStereoFromImages(
    const std::vector<cv::Mat>& left, const std::vector<cv::Mat>& right,
    const std::vector<std::string>& left_names,
    const std::vector<std::string>& right_names,
    const CalibrationOptions& options) {
  if (left.size() != right.size() || left_names.size() != left.size() ||
      right_names.size() != right.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("need as many right as left calibration images (and "
                     "names): ",
                     left.size(), " left, ", right.size(), " right"));
  }
  if (left.empty()) {
    return absl::InvalidArgumentError("no calibration images");
  }
  std::vector<std::vector<cv::Point2f>> lc, rc;
  const cv::Size size = left[0].size();
  for (size_t i = 0; i < left.size(); ++i) {
    if (left[i].size() != size || right[i].size() != size) {
      return absl::InvalidArgumentError(absl::StrCat(
          "calibration image size differs from ", left_names[0], ": ",
          left[i].size() != size ? left_names[i] : right_names[i]));
    }
    ASSIGN_OR_RETURN(
        std::vector<cv::Point2f> l,
        FindChessboard(left[i], options.board.inner_corners, left_names[i]));
    ASSIGN_OR_RETURN(
        std::vector<cv::Point2f> r,
        FindChessboard(right[i], options.board.inner_corners, right_names[i]));
    lc.push_back(std::move(l));
    rc.push_back(std::move(r));
  }
  return CalibrateStereo(lc, rc, size, options);
}

absl::StatusOr<RectificationMaps> ComputeRectificationMaps(
    const StereoCalibration& c) {
  if (c.camera_matrix.empty() || c.r1.empty() || c.p1.empty() ||
      c.image_size.area() == 0) {
    return absl::InvalidArgumentError("calibration has no rectification");
  }
  RectificationMaps maps;
  maps.image_size = c.image_size;
  try {
    cv::initUndistortRectifyMap(c.camera_matrix, c.dist_coeffs, c.r1, c.p1,
                                c.image_size, CV_32FC1, maps.left_x,
                                maps.left_y);
    cv::initUndistortRectifyMap(c.camera_matrix, c.dist_coeffs, c.r2, c.p2,
                                c.image_size, CV_32FC1, maps.right_x,
                                maps.right_y);
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("cannot compute rectification maps: ", e.what()));
  }
  return maps;
}

absl::StatusOr<cv::Mat> Rectify(const cv::Mat& image,
                                const RectificationMaps& maps, View view) {
  if (image.size() != maps.image_size) {
    return absl::InvalidArgumentError(
        absl::StrCat("image is ", image.cols, "x", image.rows,
                     " but the rig was calibrated at ", maps.image_size.width,
                     "x", maps.image_size.height));
  }
  cv::Mat out;
  try {
    const bool left = view == View::kLeft;
    cv::remap(image, out, left ? maps.left_x : maps.right_x,
              left ? maps.left_y : maps.right_y, cv::INTER_LINEAR,
              cv::BORDER_CONSTANT);
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("rectification failed: ", e.what()));
  }
  return out;
}

absl::StatusOr<std::vector<cv::Point2f>> RectifyPoints(
    const std::vector<cv::Point2f>& points, const StereoCalibration& c,
    View view) {
  std::vector<cv::Point2f> out;
  if (points.empty()) return out;
  try {
    const bool left = view == View::kLeft;
    cv::undistortPoints(points, out, c.camera_matrix, c.dist_coeffs,
                        left ? c.r1 : c.r2, left ? c.p1 : c.p2);
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("point rectification failed: ", e.what()));
  }
  return out;
}

absl::Status SaveCalibration(const std::filesystem::path& path,
                             const StereoCalibration& c) {
  std::string yaml;
  try {
    cv::FileStorage fs(".yml",
                       cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
    fs << "format"
       << "hdrstereo-stereo-calibration-1";
    fs << "image_width" << c.image_size.width;
    fs << "image_height" << c.image_size.height;
    fs << "camera_matrix" << c.camera_matrix << "dist_coeffs" << c.dist_coeffs;
    fs << "rotation" << c.rotation << "translation" << c.translation;
    fs << "rms_intrinsics" << c.rms_intrinsics << "rms_stereo" << c.rms_stereo;
    fs << "R1" << c.r1 << "R2" << c.r2 << "P1" << c.p1 << "P2" << c.p2 << "Q"
       << c.q;
    yaml = fs.releaseAndGetString();
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("cannot encode calibration for ",
                                            path.string(), ": ", e.what()));
  }
  return io::WriteFileAtomically(path, yaml);
}

absl::StatusOr<StereoCalibration> LoadCalibration(
    const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(std::string yaml, io::ReadFileBytes(path));
  StereoCalibration c;
  try {
    cv::FileStorage fs(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    std::string format;
    fs["format"] >> format;
    if (format != "hdrstereo-stereo-calibration-1") {
      return absl::InvalidArgumentError(
          absl::StrCat("not a stereo calibration file: ", path.string()));
    }
    fs["image_width"] >> c.image_size.width;
    fs["image_height"] >> c.image_size.height;
    fs["camera_matrix"] >> c.camera_matrix;
    fs["dist_coeffs"] >> c.dist_coeffs;
    fs["rotation"] >> c.rotation;
    fs["translation"] >> c.translation;
    fs["rms_intrinsics"] >> c.rms_intrinsics;
    fs["rms_stereo"] >> c.rms_stereo;
    fs["R1"] >> c.r1;
    fs["R2"] >> c.r2;
    fs["P1"] >> c.p1;
    fs["P2"] >> c.p2;
    fs["Q"] >> c.q;
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(
        "corrupt calibration file ", path.string(), ": ", e.what()));
  }
  if (c.camera_matrix.size() != cv::Size(3, 3) ||
      c.r1.size() != cv::Size(3, 3) || c.p1.size() != cv::Size(4, 3) ||
      c.image_size.area() <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("incomplete calibration file ", path.string()));
  }
  return c;
}

cv::Mat CoverageMask(const std::vector<std::vector<cv::Point2f>>& corners,
                     cv::Size image_size) {
  cv::Mat mask = cv::Mat::zeros(image_size, CV_8UC1);
  for (const std::vector<cv::Point2f>& pose : corners) {
    if (pose.size() < 3) continue;
    std::vector<cv::Point> hull;
    std::vector<cv::Point> points;
    for (const cv::Point2f& p : pose) {
      points.emplace_back(cvRound(p.x), cvRound(p.y));
    }
    cv::convexHull(points, hull);
    cv::fillConvexPoly(mask, hull, cv::Scalar(255));
  }
  return mask;
}

absl::StatusOr<CalibrationQuality> AssessCalibration(
    const StereoCalibration& calibration,
    const std::vector<std::vector<cv::Point2f>>& left,
    const std::vector<std::vector<cv::Point2f>>& right,
    const BoardSpec& board) {
  if (left.size() != right.size() || left.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("need as many left as right poses, at least one (have ",
                     left.size(), " and ", right.size(), ")"));
  }
  const std::vector<cv::Point3f> object = BoardPoints(board);
  CalibrationQuality quality;
  try {
    for (int v = 0; v < 2; ++v) {
      const auto& views = v == 0 ? left : right;
      std::vector<double>& rms = v == 0 ? quality.rms_left : quality.rms_right;
      for (const std::vector<cv::Point2f>& corners : views) {
        if (corners.size() != object.size()) {
          return absl::InvalidArgumentError(absl::StrCat(
              "a pose has ", corners.size(), " corners, not ", object.size()));
        }
        cv::Mat rvec, tvec;
        cv::solvePnP(object, corners, calibration.camera_matrix,
                     calibration.dist_coeffs, rvec, tvec);
        std::vector<cv::Point2f> projected;
        cv::projectPoints(object, rvec, tvec, calibration.camera_matrix,
                          calibration.dist_coeffs, projected);
        double sum = 0;
        for (size_t i = 0; i < corners.size(); ++i) {
          const cv::Point2f d = projected[i] - corners[i];
          sum += d.dot(d);
        }
        rms.push_back(std::sqrt(sum / static_cast<double>(corners.size())));
      }
      cv::Mat mask = CoverageMask(views, calibration.image_size);
      const double fraction =
          static_cast<double>(cv::countNonZero(mask)) /
          static_cast<double>(calibration.image_size.area());
      if (v == 0) {
        quality.coverage_left = mask;
        quality.coverage_fraction_left = fraction;
      } else {
        quality.coverage_right = mask;
        quality.coverage_fraction_right = fraction;
      }
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("assessing the calibration: ", e.what()));
  }
  return quality;
}

}  // namespace hdrstereo::calib
