// SPDX-License-Identifier: GPL-3.0-or-later
//
// The filters' option rules and canonical JSON.
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_format.h"
#include "processing/base/options.h"
#include "processing/filters/domain_transform.h"
#include "processing/filters/guided_filter.h"
#include "processing/filters/wls_filter.h"

namespace hdrstereo::filters {
namespace {

const char* PreconditionerName(WlsOptions::Preconditioner p) {
  switch (p) {
    case WlsOptions::Preconditioner::kMultigrid:
      return "multigrid";
    case WlsOptions::Preconditioner::kIncompleteCholesky:
      return "incomplete_cholesky";
  }
  return "unknown";
}

}  // namespace

absl::Status GuidedFilterOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(radius >= 1, "radius", radius, ">= 1"));
  RETURN_IF_ERROR(
      RequireField(eps > 0 && std::isfinite(eps), "eps", eps, "> 0"));
  return RequireField(subsample >= 1, "subsample", subsample,
                      ">= 1 (1 = exact filter)");
}

void to_json(nlohmann::json& j, const GuidedFilterOptions& o) {
  const auto& [radius, eps, subsample] = o;
  j = nlohmann::json{
      {"radius", radius}, {"eps", eps}, {"subsample", subsample}};
}

absl::Status DomainTransformOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(sigma_s >= kMinSigmaS && std::isfinite(sigma_s),
                               "sigma_s", sigma_s,
                               absl::StrFormat(">= %g (pixels)", kMinSigmaS)));
  RETURN_IF_ERROR(RequireField(
      sigma_r >= kMinSigmaR && std::isfinite(sigma_r), "sigma_r", sigma_r,
      absl::StrFormat(">= %g (guide units)", kMinSigmaR)));
  return RequireField(iterations >= 1, "iterations", iterations, ">= 1");
}

void to_json(nlohmann::json& j, const DomainTransformOptions& o) {
  const auto& [sigma_s, sigma_r, iterations] = o;
  j = nlohmann::json{
      {"sigma_s", sigma_s}, {"sigma_r", sigma_r}, {"iterations", iterations}};
}

absl::Status WlsOptions::Validate() const {
  RETURN_IF_ERROR(
      RequireField(alpha > 0 && std::isfinite(alpha), "alpha", alpha, "> 0"));
  RETURN_IF_ERROR(RequireField(lambda >= 0 && std::isfinite(lambda), "lambda",
                               lambda, ">= 0"));
  RETURN_IF_ERROR(
      RequireField(small_number > 0, "small_number", small_number, "> 0"));
  RETURN_IF_ERROR(RequireField(tolerance > 0, "tolerance", tolerance, "> 0"));
  return RequireField(max_iterations >= 1, "max_iterations", max_iterations,
                      ">= 1");
}

void to_json(nlohmann::json& j, const WlsOptions& o) {
  const auto& [alpha, lambda, small_number, tolerance, max_iterations,
               preconditioner] = o;
  j = nlohmann::json{{"alpha", alpha},
                     {"lambda", lambda},
                     {"small_number", small_number},
                     {"tolerance", tolerance},
                     {"max_iterations", max_iterations},
                     {"preconditioner", PreconditionerName(preconditioner)}};
}

}  // namespace hdrstereo::filters
