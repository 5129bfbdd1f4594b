// SPDX-License-Identifier: GPL-3.0-or-later
//
// The methods of the thesis experiment (Tables 5.2 / 5.3), one spelling
// each. The name is what files (disparity/<name>.pfm), metrics rows and
// tables use.
//
//   ldr                 the LDR middle exposure matched
//   reinhard .. wls     each tone-mapped pair matched (tonemap::Operator)
//   hdr                 the HDR radiance matched (HDR-CVF, Eq. 4.2)
//   mean, median        per-pixel baselines over the seven tone-mapped
//   fused-4             graph-cut fusion of 4 of the 7 (the table only:
//                       averaged over the 35 four-subsets)
//   fused               graph-cut fusion of all seven (the thesis' fused-7)
#ifndef HDRSTEREO_PROCESSING_EXPERIMENT_METHOD_H_
#define HDRSTEREO_PROCESSING_EXPERIMENT_METHOD_H_

#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::experiment {

enum class Method {
  kLdr,
  kReinhard,
  kDurand,
  kFattal,
  kDrago,
  kGuided,
  kDomainTransform,
  kWls,
  kHdr,
  kMean,
  kMedian,
  kFused4,
  kFused,
};

const char* MethodName(Method method);
// INVALID_ARGUMENT listing the names for anything else.
absl::StatusOr<Method> ParseMethod(absl::string_view name);

// The seven tone-mapped methods, in the thesis' operator order.
const std::vector<Method>& ToneMappedMethods();
// What the stereo step matches: ldr, the seven, hdr.
const std::vector<Method>& MatchedMethods();
// What the fusion step fuses the seven into: mean, median, fused.
const std::vector<Method>& FusedMethods();
// Matched then fused: every method a processed session has a map of.
const std::vector<Method>& SessionMethods();

// The operator of a tone-mapped method; nullopt for the others.
std::optional<tonemap::Operator> OperatorOf(Method method);
Method MethodOf(tonemap::Operator op);

}  // namespace hdrstereo::experiment

#endif  // HDRSTEREO_PROCESSING_EXPERIMENT_METHOD_H_
