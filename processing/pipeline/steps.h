// SPDX-License-Identifier: GPL-3.0-or-later
//
// The steps' Configure functions, by the stage file that holds them; the
// step table (step_table.cc) names them.
#ifndef HDRSTEREO_PROCESSING_PIPELINE_STEPS_H_
#define HDRSTEREO_PROCESSING_PIPELINE_STEPS_H_

#include <string>

#include "absl/status/statusor.h"
#include "processing/experiment/method.h"
#include "processing/pipeline/step.h"

namespace hdrstereo::pipeline {

// exposure_steps.cc: the stereo frames decoded, then rectified.
absl::StatusOr<ConfiguredStep> ConfigureDecode(const StepContext& context);
absl::StatusOr<ConfiguredStep> ConfigureRectify(const StepContext& context);

// hdr_steps.cc: camera response, HDR merge, the seven tone mappings.
absl::StatusOr<ConfiguredStep> ConfigureResponse(const StepContext& context);
absl::StatusOr<ConfiguredStep> ConfigureHdr(const StepContext& context);
absl::StatusOr<ConfiguredStep> ConfigureTonemap(const StepContext& context);
// Where the tonemap step writes method m's view (0 left, 1 right), relative
// to the session folder ("tonemapped/<method>/im<view>.png"), which the
// stereo, fusion and report steps read.
std::string ToneMappedFile(experiment::Method m, int view);

// ground_truth_step.cc: the structured-light ground truth.
absl::StatusOr<ConfiguredStep> ConfigureStructuredLight(
    const StepContext& context);

// matching_steps.cc: every method matched, then fused.
absl::StatusOr<ConfiguredStep> ConfigureStereo(const StepContext& context);
absl::StatusOr<ConfiguredStep> ConfigureFusion(const StepContext& context);

// output_steps.cc: metrics, the Middlebury export, the HTML report.
absl::StatusOr<ConfiguredStep> ConfigureEvaluate(const StepContext& context);
absl::StatusOr<ConfiguredStep> ConfigureExport(const StepContext& context);
absl::StatusOr<ConfiguredStep> ConfigureReport(const StepContext& context);

}  // namespace hdrstereo::pipeline

#endif  // HDRSTEREO_PROCESSING_PIPELINE_STEPS_H_
