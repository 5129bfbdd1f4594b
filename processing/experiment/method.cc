// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/experiment/method.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace hdrstereo::experiment {
namespace {

// Every method, in the enum's order.
constexpr Method kAll[] = {Method::kLdr,
                           Method::kReinhard,
                           Method::kDurand,
                           Method::kFattal,
                           Method::kDrago,
                           Method::kGuided,
                           Method::kDomainTransform,
                           Method::kWls,
                           Method::kHdr,
                           Method::kMean,
                           Method::kMedian,
                           Method::kFused4,
                           Method::kFused};

}  // namespace

const char* MethodName(Method method) {
  // By the enum's value; the tone-mapped methods are named for their
  // operators.
  static const std::vector<std::string>* names = [] {
    auto* v = new std::vector<std::string>();
    for (Method m : kAll) {
      const std::optional<tonemap::Operator> op = OperatorOf(m);
      v->push_back(op ? tonemap::OperatorName(*op) : [m] {
        switch (m) {
          case Method::kLdr:
            return "ldr";
          case Method::kHdr:
            return "hdr";
          case Method::kMean:
            return "mean";
          case Method::kMedian:
            return "median";
          case Method::kFused4:
            return "fused-4";
          default:
            return "fused";
        }
      }());
    }
    return v;
  }();
  return (*names)[static_cast<size_t>(method)].c_str();
}

absl::StatusOr<Method> ParseMethod(absl::string_view name) {
  std::vector<std::string> names;
  for (Method m : kAll) {
    if (name == MethodName(m)) return m;
    names.push_back(MethodName(m));
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown method \"", name, "\"; known: ", absl::StrJoin(names, ", ")));
}

const std::vector<Method>& ToneMappedMethods() {
  static const std::vector<Method>* m = [] {
    auto* v = new std::vector<Method>();
    for (tonemap::Operator op : tonemap::AllOperators()) {
      v->push_back(MethodOf(op));
    }
    return v;
  }();
  return *m;
}

const std::vector<Method>& MatchedMethods() {
  static const std::vector<Method>* m = [] {
    auto* v = new std::vector<Method>{Method::kLdr};
    for (Method t : ToneMappedMethods()) v->push_back(t);
    v->push_back(Method::kHdr);
    return v;
  }();
  return *m;
}

const std::vector<Method>& FusedMethods() {
  static const std::vector<Method>* m =
      new std::vector<Method>{Method::kMean, Method::kMedian, Method::kFused};
  return *m;
}

const std::vector<Method>& SessionMethods() {
  static const std::vector<Method>* m = [] {
    auto* v = new std::vector<Method>(MatchedMethods());
    for (Method f : FusedMethods()) v->push_back(f);
    return v;
  }();
  return *m;
}

std::optional<tonemap::Operator> OperatorOf(Method method) {
  switch (method) {
    case Method::kReinhard:
      return tonemap::Operator::kReinhard;
    case Method::kDurand:
      return tonemap::Operator::kDurand;
    case Method::kFattal:
      return tonemap::Operator::kFattal;
    case Method::kDrago:
      return tonemap::Operator::kDrago;
    case Method::kGuided:
      return tonemap::Operator::kGuided;
    case Method::kDomainTransform:
      return tonemap::Operator::kDomainTransform;
    case Method::kWls:
      return tonemap::Operator::kWls;
    default:
      return std::nullopt;
  }
}

Method MethodOf(tonemap::Operator op) {
  switch (op) {
    case tonemap::Operator::kReinhard:
      return Method::kReinhard;
    case tonemap::Operator::kDurand:
      return Method::kDurand;
    case tonemap::Operator::kFattal:
      return Method::kFattal;
    case tonemap::Operator::kDrago:
      return Method::kDrago;
    case tonemap::Operator::kGuided:
      return Method::kGuided;
    case tonemap::Operator::kDomainTransform:
      return Method::kDomainTransform;
    case tonemap::Operator::kWls:
      return Method::kWls;
  }
  return Method::kReinhard;
}

}  // namespace hdrstereo::experiment
