// SPDX-License-Identifier: GPL-3.0-or-later
//
// A bundled simulated scene as the thesis' experiment sees it: both views
// rendered with the thesis' eight exposures (1/15 .. 1/2000 s, ISO 100,
// 8-bit) from stage positions 0 and 150 mm, with the simulator's exact
// left-view truth and non-occlusion mask; LDR = 1/250 s.
#ifndef HDRSTEREO_TESTS_SUPPORT_THESIS_SCENE_H_
#define HDRSTEREO_TESTS_SUPPORT_THESIS_SCENE_H_

#include <string>

#include "absl/status/statusor.h"
#include "processing/experiment/thesis_table.h"

namespace hdrstereo::testing {

absl::StatusOr<experiment::TableInput> RenderThesisScene(
    const std::string& name, int width);

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_THESIS_SCENE_H_
