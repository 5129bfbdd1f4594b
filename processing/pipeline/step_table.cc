// SPDX-License-Identifier: GPL-3.0-or-later
//
// The step table and what is derived from it (names, dependencies, the
// steps a request resolves to).
#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "processing/pipeline/pipeline.h"
#include "processing/pipeline/step.h"
#include "processing/pipeline/steps.h"

namespace hdrstereo::pipeline {

const std::vector<StepSpec>& StepTable() {
  using In = StepInputs;
  static const std::vector<StepSpec>* table = new std::vector<StepSpec>{
      {"decode", {}, In::kStereoFrames, &ConfigureDecode},
      {"rectify", {"decode"}, In::kCalibrationFrames, &ConfigureRectify},
      {"response", {"rectify"}, In::kNone, &ConfigureResponse},
      {"hdr", {"rectify", "response"}, In::kNone, &ConfigureHdr},
      {"tonemap", {"hdr"}, In::kNone, &ConfigureTonemap},
      {"sl_groundtruth",
       {},
       In::kStructuredLightFrames,
       &ConfigureStructuredLight},
      {"stereo",
       {"rectify", "hdr", "tonemap", "sl_groundtruth"},
       In::kSimulatorTruth,
       &ConfigureStereo},
      {"fusion",
       {"rectify", "tonemap", "stereo", "sl_groundtruth"},
       In::kSimulatorTruth,
       &ConfigureFusion},
      {"evaluate",
       {"stereo", "fusion", "sl_groundtruth"},
       In::kSimulatorTruth,
       &ConfigureEvaluate},
      {"export",
       {"rectify", "sl_groundtruth"},
       In::kSimulatorTruth,
       &ConfigureExport},
      {"report",
       {"rectify", "tonemap", "stereo", "fusion", "sl_groundtruth", "evaluate"},
       In::kSimulatorTruth,
       &ConfigureReport},
  };
  return *table;
}

const std::vector<std::string>& AllSteps() {
  static const std::vector<std::string>* all = [] {
    auto* v = new std::vector<std::string>();
    for (const StepSpec& s : StepTable()) v->push_back(s.name);
    return v;
  }();
  return *all;
}

const std::vector<std::string>& StepDependencies(const std::string& step) {
  static const std::vector<std::string>* none = new std::vector<std::string>();
  for (const StepSpec& s : StepTable()) {
    if (s.name == step) return s.deps;
  }
  return *none;
}

absl::StatusOr<std::vector<std::string>> ResolveSteps(
    const std::vector<std::string>& requested) {
  if (requested.empty()) return AllSteps();
  std::set<std::string> wanted;
  std::vector<std::string> stack;
  for (const std::string& r : requested) {
    if (std::find(AllSteps().begin(), AllSteps().end(), r) ==
        AllSteps().end()) {
      return absl::InvalidArgumentError(
          absl::StrCat("unknown step \"", r,
                       "\"; known steps: ", absl::StrJoin(AllSteps(), ", ")));
    }
    stack.push_back(r);
  }
  while (!stack.empty()) {
    const std::string s = stack.back();
    stack.pop_back();
    if (!wanted.insert(s).second) continue;
    for (const std::string& d : StepDependencies(s)) stack.push_back(d);
  }
  std::vector<std::string> out;
  for (const std::string& s : AllSteps()) {
    if (wanted.count(s)) out.push_back(s);
  }
  return out;
}

}  // namespace hdrstereo::pipeline
