// SPDX-License-Identifier: GPL-3.0-or-later
//
// Fusion of several disparity maps of one view (thesis 5.2.2, Appendix A):
// a pairwise MRF over integer disparity labels [0, max_disp], minimised by
// graph-cut alpha-expansion (Boykov, Veksler, Zabih 2001) on the
// Boykov-Kolmogorov max-flow of libmaxflow.
//
// Energy (integers, so the cut is exact):
//   E(f) = sum_p D_p(f_p) + sum_{p~q, 4-neighbours} w_pq * rho(f_p, f_q)
//
// Data term D (Appendix A `initialize_costvolume`, Dc = d1 + ... + d7): for
// every valid candidate k with disparity z_k(p) and confidence c_k(p) (1 when
// no confidences are given)
//   kGaussian:  D_p(l) += round(data_scale * c_k * (1 - exp(-(l - z)^2 /
//                                                             (2 sigma^2))))
//               (the negated normal likelihood: bounded, so one wrong
//               candidate costs at most data_scale);
//   kQuadratic: D_p(l) += round(data_scale * c_k * min((l - z)^2,
//                                                      data_truncation))
//               (Eq. 5.4, psi = sum K (y - z)^2, with K = data_scale).
// A candidate is invalid at p when z is not finite, negative or larger than
// max_disp + 0.5; invalid candidates contribute nothing (a pixel with no
// valid candidate has a flat data term and takes its label from the
// smoothness term).
//
// Smoothness w_pq * rho, from the guide (left) image converted to 8-bit grey,
// g = |I_p - I_q|:
//   kPottsLinear (default, Appendix A smoothFunc 3, "Potts x linear weight"):
//       g < static_cue -> g = 0; w = lambda * max(linear_model_thr - g, 1),
//       rho = [f_p != f_q];
//   kPotts:          w = lambda * linear_model_thr, rho = [f_p != f_q];
//   kPottsStaticCue: w = lambda * ((g <= static_cue) + 1), rho = Potts;
//   (times edge_weight where the pair's right / lower pixel is a guide edge)
//   kQuadratic (Eqs. 5.5-5.7): w = lambda * linear_model_thr * exp(-c g^2)
//       with g on [0, 1] grey, rho = min((f_p - f_q)^2, quadratic_truncation).
//       (4-neighbours here; the thesis' Eq. 5.5 uses 8).
//       This rho is not a metric, so an expansion move can be
//       non-submodular; such pairwise terms are truncated (Rother et al.
//       2005) and a move is only accepted when the true energy drops.
//
// Solver: start from the per-pixel data minimum (winner takes all), then
// cycle over all labels; for label alpha build the binary expansion graph
// (reusing one maxflow::Graph's memory: Graph::reset()), cut, accept the move
// if the energy decreases; stop after a cycle with no accepted move. Pixels
// whose data increase D_p(alpha) - D_p(f_p) exceeds the largest smoothness
// saving sum_q w_pq * rho_max cannot switch in any optimal move (they are
// dominated), so they are not put in the graph: this is exact and keeps the
// graphs small. With the Potts models the saving only counts edges to
// neighbours that are at alpha or may switch, and an expansion is skipped
// when no pixel that could switch to alpha, nor a neighbour of one, has
// changed since alpha's last expansion (that move would be rejected). All
// of this is exact: max-flow returns the smallest optimal set of switching
// pixels, which none of it changes, so the labelling is the same as with
// full graphs.
//
// The fusion-move variant (`candidate_labels_only`) lets a pixel switch to
// alpha only when alpha is within `candidate_label_radius` of one of its
// valid candidates; it is faster and no longer a full alpha-expansion.
#ifndef HDRSTEREO_PROCESSING_FUSION_FUSION_H_
#define HDRSTEREO_PROCESSING_FUSION_FUSION_H_

#include <cmath>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::fusion {

enum class DataModel { kGaussian, kQuadratic };
enum class SmoothnessModel {
  kPottsLinear,
  kPotts,
  kPottsStaticCue,
  kQuadratic
};

struct FusionOptions {
  int max_disp = 64;  // labels 0..max_disp
  DataModel data = DataModel::kGaussian;
  double sigma = 1.0;             // kGaussian, in pixels
  double data_scale = 64.0;       // per candidate
  double data_truncation = 16.0;  // kQuadratic, in px^2
  SmoothnessModel smoothness = SmoothnessModel::kPottsLinear;
  double lambda = 1.0;
  double linear_model_thr = 40.0;  // Appendix A linearModelThr
  double static_cue = 8.0;         // Appendix A sCue
  double quadratic_c = 50.0;       // Eq. 5.6, on [0, 1] grey
  int quadratic_truncation = 4;    // rho cap for kQuadratic
  // Appendix A `useEdge`: the weight of a pair whose right / lower pixel is
  // an edge pixel of the guide (MATLAB edge(): Sobel, threshold 4 x the mean
  // squared gradient, thinned; any colour channel) is multiplied by this.
  // Appendix A uses eps (~0); 1 leaves the weights as they are.
  double edge_weight = 1.0;
  int max_cycles = 20;
  // Leave dominated pixels out of the expansion graphs and skip expansions
  // that cannot change anything (both exact; see above). false builds the
  // full graph of every pixel not at alpha in every expansion (comparison).
  bool prune_dominated = true;
  bool candidate_labels_only = false;  // fusion-move variant
  int candidate_label_radius = 1;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const FusionOptions& o);

// The integer MRF the solver works on. Edge weights: right[p] is the edge
// (p, p + 1) (0 in the last column), down[p] the edge (p, p + width) (0 in the
// last row). The data term is given densely, label-major (data[l * width *
// height + p]), or sparsely (far / near_begin / near below), or both.
struct MrfProblem {
  int width = 0;
  int height = 0;
  int num_labels = 0;
  std::vector<uint16_t> data;
  std::vector<int32_t> right;
  std::vector<int32_t> down;
  bool potts = true;       // rho = [a != b]; else min((a-b)^2, trunc)
  int32_t truncation = 1;  // rho cap for the quadratic case
  // Optional per-pixel allowed labels (fusion-move variant): when not empty,
  // allowed[l * N + p] != 0 iff pixel p may take label l.
  std::vector<uint8_t> allowed;
  // The data term, sparsely (BuildProblem gives only this; when it is empty
  // the solver derives it from `data`): for pixel p, near[near_begin[p] ..
  // near_begin[p + 1]) lists by ascending label every label whose cost is
  // below far[p], with that cost; every other label costs exactly far[p].
  // Fusion costs are the sum of each candidate's bounded cost, so only the
  // labels near some candidate are listed: the solver finds a pixel's cheap
  // labels without reading num_labels costs, and the dense volume is not
  // needed.
  struct NearCost {
    uint16_t label = 0;
    uint16_t cost = 0;
  };
  std::vector<uint16_t> far;
  std::vector<int64_t> near_begin;  // width * height + 1 offsets
  std::vector<NearCost> near;
};

struct SolverStats {
  int64_t energy_before = 0;  // of the initial labelling
  int64_t energy_after = 0;
  int cycles = 0;
  int expansions = 0;        // max-flow calls
  int skipped = 0;           // expansions proven unable to change anything
  int accepted = 0;          // moves that lowered the energy
  int64_t graph_nodes = 0;   // summed over expansions
  double setup_seconds = 0;  // data term + WTA (FuseAlphaExpansion only)
  // Everything of AlphaExpansion but max-flow: per-pixel state, per-label
  // lists, pruning scans, graph construction, move bookkeeping.
  double build_seconds = 0;
  double index_seconds = 0;    // of build_seconds: the lists etc., made once
  double maxflow_seconds = 0;  // inside maxflow::Graph::maxflow()
  double total_seconds = 0;
};

// What the steps after the graph cuts changed (reliability.h); zero for
// the other fusions.
struct RefinementCounts {
  int segments = 0;             // the plane prior's, in the view
  int planes = 0;               // of them, those that took a plane
  double plane_fraction = 0;    // of the pixels: replaced by a plane,
  double photo_fraction = 0;    // by a candidate the views agree with,
  double speckle_fraction = 0;  // removed as an island and filled
};

struct FusionResult {
  cv::Mat disparity;  // CV_32FC1, integer labels (but see FuseByReliability)
  SolverStats stats;
  RefinementCounts refinement;
};

// Builds the MRF from candidates (CV_32FC1, same size) and the guide (8-bit
// or float [0, 1], 1 or 3 channels, same size). confidences: empty or one
// CV_32FC1 map in [0, 1] per candidate.
absl::StatusOr<MrfProblem> BuildProblem(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionOptions& params, const std::vector<cv::Mat>& confidences = {});

int64_t Energy(const MrfProblem& problem, const std::vector<int32_t>& labels);

// Per-pixel argmin of the data term (first minimum; respects `allowed`).
std::vector<int32_t> WinnerTakesAll(const MrfProblem& problem);

// Alpha-expansion from *labels (size width * height, values in range). The
// energy never increases.
absl::StatusOr<SolverStats> AlphaExpansion(const MrfProblem& problem,
                                           std::vector<int32_t>* labels,
                                           int max_cycles = 20,
                                           bool prune_dominated = true);

// BuildProblem + WinnerTakesAll + AlphaExpansion.
absl::StatusOr<FusionResult> FuseAlphaExpansion(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionOptions& params, const std::vector<cv::Mat>& confidences = {});

// The validity rule above, shared by every step of the fusion: finite and
// in [0, max_disp + 0.5] (what the graph cut can label).
inline bool IsValidDisparity(float z, int max_disp) {
  return std::isfinite(z) && z >= 0.0f &&
         z <= static_cast<float>(max_disp) + 0.5f;
}

// INVALID_ARGUMENT unless there is a candidate and every one is a
// non-empty CV_32FC1 map of candidate 0's size (the message names the
// first that is not): the check every fusion here makes first.
absl::Status CheckCandidateMaps(const std::vector<cv::Mat>& candidates);

// Baselines: per-pixel mean / median of the valid candidates (same validity
// rule); NaN where no candidate is valid. CV_32FC1.
absl::StatusOr<cv::Mat> FuseMean(const std::vector<cv::Mat>& candidates,
                                 int max_disp);
absl::StatusOr<cv::Mat> FuseMedian(const std::vector<cv::Mat>& candidates,
                                   int max_disp);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_FUSION_FUSION_H_
