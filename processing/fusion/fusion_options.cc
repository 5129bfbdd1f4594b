// SPDX-License-Identifier: GPL-3.0-or-later
//
// FusionOptions' rules and canonical JSON.
#include <nlohmann/json.hpp>

#include "processing/base/options.h"
#include "processing/fusion/fusion.h"

namespace hdrstereo::fusion {
namespace {

const char* DataModelName(DataModel model) {
  switch (model) {
    case DataModel::kGaussian:
      return "gaussian";
    case DataModel::kQuadratic:
      return "quadratic";
  }
  return "unknown";
}

const char* SmoothnessModelName(SmoothnessModel model) {
  switch (model) {
    case SmoothnessModel::kPottsLinear:
      return "potts_linear";
    case SmoothnessModel::kPotts:
      return "potts";
    case SmoothnessModel::kPottsStaticCue:
      return "potts_static_cue";
    case SmoothnessModel::kQuadratic:
      return "quadratic";
  }
  return "unknown";
}

}  // namespace

absl::Status FusionOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(max_disp >= 1 && max_disp <= 4096, "max_disp",
                               max_disp, "in [1, 4096]"));
  RETURN_IF_ERROR(RequireField(sigma > 0, "sigma", sigma, "> 0"));
  RETURN_IF_ERROR(
      RequireField(data_scale > 0, "data_scale", data_scale, "> 0"));
  RETURN_IF_ERROR(RequireField(data_truncation > 0, "data_truncation",
                               data_truncation, "> 0"));
  RETURN_IF_ERROR(RequireField(lambda >= 0 && lambda <= 1e4, "lambda", lambda,
                               "in [0, 1e4]"));
  RETURN_IF_ERROR(RequireField(linear_model_thr >= 1 && linear_model_thr <= 1e4,
                               "linear_model_thr", linear_model_thr,
                               "in [1, 1e4]"));
  RETURN_IF_ERROR(RequireField(quadratic_truncation >= 1,
                               "quadratic_truncation", quadratic_truncation,
                               ">= 1"));
  RETURN_IF_ERROR(RequireField(edge_weight >= 0 && edge_weight <= 1,
                               "edge_weight", edge_weight, "in [0, 1]"));
  RETURN_IF_ERROR(RequireField(max_cycles >= 0, "max_cycles", max_cycles,
                               ">= 0 (0 = winner takes all)"));
  return RequireField(candidate_label_radius >= 0, "candidate_label_radius",
                      candidate_label_radius, ">= 0");
}

void to_json(nlohmann::json& j, const FusionOptions& o) {
  const auto& [max_disp, data, sigma, data_scale, data_truncation, smoothness,
               lambda, linear_model_thr, static_cue, quadratic_c,
               quadratic_truncation, edge_weight, max_cycles, prune_dominated,
               candidate_labels_only, candidate_label_radius] = o;
  j = nlohmann::json{{"max_disp", max_disp},
                     {"data", DataModelName(data)},
                     {"sigma", sigma},
                     {"data_scale", data_scale},
                     {"data_truncation", data_truncation},
                     {"smoothness", SmoothnessModelName(smoothness)},
                     {"lambda", lambda},
                     {"linear_model_thr", linear_model_thr},
                     {"static_cue", static_cue},
                     {"quadratic_c", quadratic_c},
                     {"quadratic_truncation", quadratic_truncation},
                     {"edge_weight", edge_weight},
                     {"max_cycles", max_cycles},
                     {"prune_dominated", prune_dominated},
                     {"candidate_labels_only", candidate_labels_only},
                     {"candidate_label_radius", candidate_label_radius}};
}

}  // namespace hdrstereo::fusion
