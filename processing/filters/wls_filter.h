// SPDX-License-Identifier: GPL-3.0-or-later
//
// Weighted-least-squares edge-preserving smoothing (Farbman, Fattal,
// Lischinski & Szeliski, SIGGRAPH 2008, Eq. 1-4):
//
//   u = argmin sum_p (u_p - g_p)^2
//             + lambda (a_x,p (du/dx)_p^2 + a_y,p (du/dy)_p^2),
//   a_x,p = 1 / (|dl/dx|_p^alpha + small), likewise a_y,
//
// i.e. the sparse SPD system (I + lambda L_g) u = g with L_g the 5-point
// Laplacian weighted by a (forward differences, Neumann boundary), l the
// guide (Farbman uses the log-luminance). Solved by conjugate gradients,
// starting from u = g, until ||g - A u|| <= tolerance * ||g||, preconditioned
// by an aggregation-multigrid V-cycle (2x2 piecewise-constant aggregation,
// Galerkin coarse operators, symmetric Gauss-Seidel smoothing; default) or by
// incomplete Cholesky IC(0). A real solve of the full system, not an
// approximation by separable 1-D passes.
#ifndef HDRSTEREO_PROCESSING_FILTERS_WLS_FILTER_H_
#define HDRSTEREO_PROCESSING_FILTERS_WLS_FILTER_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::filters {

struct WlsOptions {
  double alpha = 1.2;          // gradient sensitivity exponent
  double lambda = 1.0;         // smoothness weight
  double small_number = 1e-4;  // avoids division by zero in flat regions
  double tolerance = 1e-4;     // relative residual ||g - A u|| / ||g||
  int max_iterations = 2000;
  enum class Preconditioner {
    kMultigrid,           // aggregation multigrid V-cycle (default)
    kIncompleteCholesky,  // IC(0)
  };
  Preconditioner preconditioner = Preconditioner::kMultigrid;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const WlsOptions& o);

struct WlsReport {
  int iterations = 0;
  double relative_residual = 0.0;  // reached; > tolerance means not converged
};

// src: CV_8U or CV_32F, any number of channels (each solved with the same
// matrix). guide: CV_8U/CV_32F, 1 channel, same size; empty means src (which
// must then have 1 channel). Returns CV_32F with src's channels. Not
// converging within max_iterations is not an error: the best iterate is
// returned and `report` (optional) tells.
absl::StatusOr<cv::Mat> WlsFilter(const cv::Mat& src, const cv::Mat& guide,
                                  const WlsOptions& options = {},
                                  WlsReport* report = nullptr);

}  // namespace hdrstereo::filters

#endif  // HDRSTEREO_PROCESSING_FILTERS_WLS_FILTER_H_
