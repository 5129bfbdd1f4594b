// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/ground_truth.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/middlebury.h"

namespace hdrstereo::structured_light {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Combines view and illumination disparities of one view in place.
void Combine(const cv::Mat& illumination, double tol, cv::Mat* disparity,
             ViewStats* stats) {
  double sum = 0;
  for (int y = 0; y < disparity->rows; ++y) {
    float* d = disparity->ptr<float>(y);
    const float* il = illumination.ptr<float>(y);
    for (int x = 0; x < disparity->cols; ++x) {
      const bool view = std::isfinite(d[x]);
      const bool illum = std::isfinite(il[x]);
      if (view && illum) {
        const double diff = std::abs(d[x] - il[x]);
        if (diff <= tol) {
          ++stats->agree;
          sum += diff;
        } else {
          ++stats->inconsistent;
          d[x] = kInf;
        }
      } else if (illum) {
        d[x] = il[x];
        ++stats->illumination_only;
      }
    }
  }
  stats->mean_abs_difference = stats->agree > 0 ? sum / stats->agree : 0;
}

// Fills small holes of lit pixels on one surface; counts what stays open.
void FillHoles(const cv::Mat& lit, const GroundTruthOptions& o,
               cv::Mat* disparity, ViewStats* stats) {
  const cv::Mat valid = *disparity != kInf;
  const cv::Mat lit_holes = lit & ~valid;
  cv::Mat labels, cc_stats, centroids;
  const int n = cv::connectedComponentsWithStats(lit_holes, labels, cc_stats,
                                                 centroids, 8, CV_32S);
  std::vector<std::vector<cv::Point>> members(n);
  for (int y = 0; y < labels.rows; ++y) {
    const int32_t* l = labels.ptr<int32_t>(y);
    for (int x = 0; x < labels.cols; ++x) {
      if (l[x] > 0 &&
          cc_stats.at<int32_t>(l[x], cv::CC_STAT_AREA) <= o.max_hole_area) {
        members[l[x]].emplace_back(x, y);
      }
    }
  }
  const cv::Mat before = disparity->clone();
  auto value = [&](int x, int y) -> float {
    if (x < 0 || y < 0 || x >= before.cols || y >= before.rows) return kInf;
    return before.at<float>(y, x);
  };
  static const int kDirs[8][2] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                  {1, 1}, {-1, 1}, {1, -1}, {-1, -1}};
  for (int c = 1; c < n; ++c) {
    const int area = cc_stats.at<int32_t>(c, cv::CC_STAT_AREA);
    if (area > o.max_hole_area) {
      ++stats->holes_left;
      stats->hole_pixels_left += area;
      continue;
    }
    // Border: valid 8-neighbours of the hole.
    float lo = kInf, hi = -kInf;
    int border = 0;
    bool touches_unlit = false;
    for (const cv::Point& p : members[c]) {
      for (const auto& d : kDirs) {
        const int nx = p.x + d[0], ny = p.y + d[1];
        if (nx >= 0 && ny >= 0 && nx < lit.cols && ny < lit.rows &&
            !lit.at<uint8_t>(ny, nx)) {
          touches_unlit = true;
        }
        const float v = value(nx, ny);
        if (std::isfinite(v)) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
          ++border;
        }
      }
    }
    // A hole at the edge of a projector shadow is not filled: the shadow
    // edge is not known to the pixel.
    if (touches_unlit || border < 3 || hi - lo > o.max_fill_range) {
      ++stats->holes_left;
      stats->hole_pixels_left += area;
      continue;
    }
    const int reach = static_cast<int>(std::ceil(std::sqrt(area))) + 2;
    for (const cv::Point& p : members[c]) {
      double sum = 0, weight = 0;
      for (const auto& d : kDirs) {
        for (int k = 1; k <= reach; ++k) {
          const float v = value(p.x + k * d[0], p.y + k * d[1]);
          if (std::isfinite(v)) {
            const double w = 1.0 / (k * std::hypot(d[0], d[1]));
            sum += w * v;
            weight += w;
            break;
          }
        }
      }
      if (weight > 0) {
        disparity->at<float>(p.y, p.x) = static_cast<float>(sum / weight);
        ++stats->hole_filled;
      }
    }
  }
  // Unlit regions (projector shadow, saturated lamp) stay invalid.
  const cv::Mat unlit = ~lit;
  stats->unlit_pixels = cv::countNonZero(unlit);
  const int m = cv::connectedComponentsWithStats(unlit, labels, cc_stats,
                                                 centroids, 8, CV_32S);
  for (int c = 1; c < m; ++c) {
    if (cc_stats.at<int32_t>(c, cv::CC_STAT_AREA) >= o.max_hole_area) {
      ++stats->unlit_regions;
    }
  }
}

cv::Mat OcclusionMask(const cv::Mat& disp0, const cv::Mat& disp1, double tol) {
  cv::Mat mask(disp0.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < disp0.rows; ++y) {
    const float* d = disp0.ptr<float>(y);
    const float* o = disp1.ptr<float>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < disp0.cols; ++x) {
      if (!std::isfinite(d[x])) continue;
      const double xr = x - d[x];
      const int x0 = static_cast<int>(std::floor(xr));
      m[x] = 128;
      for (int xi = x0; xi <= x0 + 1; ++xi) {
        if (xi >= 0 && xi < disp1.cols && std::isfinite(o[xi]) &&
            std::abs(o[xi] - d[x]) <= tol) {
          m[x] = 255;
        }
      }
    }
  }
  return mask;
}

}  // namespace

absl::StatusOr<GroundTruth> ComputeGroundTruth(
    const DecodedView& left, const DecodedView& right,
    const GroundTruthOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("ground truth: ", s.message()));
  }
  if (left.column.empty() || right.column.empty()) {
    return absl::InvalidArgumentError("ground truth: a view is not decoded");
  }
  if (left.column.size() != right.column.size()) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "ground truth: left view is %dx%d but right view is %dx%d",
        left.column.cols, left.column.rows, right.column.cols,
        right.column.rows));
  }
  try {
    GroundTruth out;
    const DecodedView* views[2] = {&left, &right};
    SubpixelCodes codes[2];
    for (int v = 0; v < 2; ++v) {
      codes[v] = ComputeSubpixelCodes(*views[v], options.match);
      ViewStats& s = out.stats.view[v];
      s.pixels = views[v]->column.size().area();
      s.lit = cv::countNonZero(views[v]->lit);
      s.decoded = cv::countNonZero(views[v]->column >= 0);
    }
    ASSIGN_OR_RETURN(ViewDisparity vd,
                     ComputeViewDisparity(codes[0], codes[1], options.match));
    out.disp0 = vd.left;
    out.disp1 = vd.right;
    out.stats.view[0].lr_rejected = vd.left_rejected;
    out.stats.view[1].lr_rejected = vd.right_rejected;
    out.stats.view[0].view_matched = cv::countNonZero(out.disp0 != kInf);
    out.stats.view[1].view_matched = cv::countNonZero(out.disp1 != kInf);

    if (options.use_illumination) {
      absl::StatusOr<ProjectorMatrix> p =
          EstimateProjectorMatrix(codes[0], out.disp0, options.projector);
      if (!p.ok()) {
        out.warnings.push_back(absl::StrCat("no illumination disparities: ",
                                            p.status().message()));
      } else {
        out.projector = *p;
        out.stats.projector_fitted = true;
        out.stats.projector_samples = p->samples;
        out.stats.projector_inliers = p->inliers;
        out.stats.projector_rms_px = p->rms_px;
        const double max_d = options.match.max_disparity > 0
                                 ? options.match.max_disparity
                                 : left.column.cols;
        const cv::Matx34d* matrices[2] = {&p->left, &p->right};
        cv::Mat* maps[2] = {&out.disp0, &out.disp1};
        for (int v = 0; v < 2; ++v) {
          const cv::Mat illum = IlluminationDisparity(
              codes[v], *matrices[v], options.match.min_disparity, max_d,
              options.max_illumination_residual_px);
          Combine(illum, options.consistency_px, maps[v], &out.stats.view[v]);
        }
        if (p->rms_px > 0.75) {
          out.warnings.push_back(absl::StrFormat(
              "projector matrix reprojects with %.2f px RMS: the views may "
              "not be rectified or the projector moved",
              p->rms_px));
        }
      }
    }
    FillHoles(left.lit, options, &out.disp0, &out.stats.view[0]);
    FillHoles(right.lit, options, &out.disp1, &out.stats.view[1]);
    for (int v = 0; v < 2; ++v) {
      const cv::Mat& d = v == 0 ? out.disp0 : out.disp1;
      ViewStats& s = out.stats.view[v];
      const cv::Mat valid = d != kInf;
      s.valid = cv::countNonZero(valid);
      s.coverage_of_lit =
          s.lit > 0
              ? static_cast<double>(cv::countNonZero(valid & views[v]->lit)) /
                    s.lit
              : 0.0;
    }
    out.mask0nocc =
        OcclusionMask(out.disp0, out.disp1, options.match.lr_tolerance);
    out.stats.nonoccluded = cv::countNonZero(out.mask0nocc == 255);
    out.stats.occluded = cv::countNonZero(out.mask0nocc == 128);
    if (out.stats.view[0].valid == 0) {
      out.warnings.push_back(
          "no pixel has a ground-truth disparity: all-invalid maps (is the "
          "projector lit and visible in both views?)");
    }
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("ground truth: ", e.what()));
  }
}

std::string StatsJson(const GroundTruthStats& stats) {
  std::string out = "{\n  \"views\": [\n";
  for (int v = 0; v < 2; ++v) {
    const ViewStats& s = stats.view[v];
    absl::StrAppendFormat(
        &out,
        "    {\"view\": \"%s\", \"pixels\": %d, \"lit\": %d, \"decoded\": %d, "
        "\"view_matched\": %d, \"lr_rejected\": %d, \"illumination_only\": "
        "%d, \"agree\": %d, \"inconsistent\": %d, \"mean_abs_difference_px\": "
        "%.4f, \"hole_filled\": %d, \"holes_left\": %d, "
        "\"hole_pixels_left\": %d, \"unlit_regions\": %d, \"unlit_pixels\": "
        "%d, \"valid\": %d, \"coverage_of_lit\": %.5f}%s\n",
        v == 0 ? "left" : "right", s.pixels, s.lit, s.decoded, s.view_matched,
        s.lr_rejected, s.illumination_only, s.agree, s.inconsistent,
        s.mean_abs_difference, s.hole_filled, s.holes_left, s.hole_pixels_left,
        s.unlit_regions, s.unlit_pixels, s.valid, s.coverage_of_lit,
        v == 0 ? "," : "");
  }
  absl::StrAppendFormat(
      &out,
      "  ],\n  \"nonoccluded\": %d,\n  \"occluded\": %d,\n"
      "  \"projector\": {\"fitted\": %s, \"samples\": %d, \"inliers\": %d, "
      "\"rms_px\": %.4f}\n}\n",
      stats.nonoccluded, stats.occluded,
      stats.projector_fitted ? "true" : "false", stats.projector_samples,
      stats.projector_inliers, stats.projector_rms_px);
  return out;
}

absl::Status WriteMiddlebury(const GroundTruth& truth,
                             const std::filesystem::path& dir) {
  RETURN_IF_ERROR(
      io::WriteGroundTruth(dir, truth.disp0, truth.mask0nocc, truth.disp1));
  return io::WriteFileAtomically(dir / kStatsFile, StatsJson(truth.stats));
}

}  // namespace hdrstereo::structured_light
