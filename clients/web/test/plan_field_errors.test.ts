// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { fieldError } from "../src/plan_field_errors";
import { kPlanFields } from "../src/capture_plan";

const stereo = ["session", ...kPlanFields.bracketed_stereo];
const sl = ["session", ...kPlanFields.structured_light];
const calibration = ["session", ...kPlanFields.calibration];

// Each message as daemon/jobs/capture_plan.cc (and the code it calls) words it.
test("a path with an index names the list and the entry", () => {
  const m = "bracketed_stereo.exposures_s[2] is 0 s; exposures must be in (0, 3600] s";
  assert.deepEqual(fieldError(m, stereo), { field: "bracketed_stereo.exposures_s", index: 2, message: m });
});

test("nested option paths name the nested field", () => {
  const m = "bracketed_stereo.auto_bracket.min_snr is 5; it must be in [10, 1000] (10: ISO 12232 \"acceptable\")";
  assert.equal(fieldError(m, stereo).field, "bracketed_stereo.auto_bracket.min_snr");
  const probe = "structured_light.projector_probe.step_s is 2; use 0 (0.02 s) or a time in (0, 1] s";
  assert.equal(fieldError(probe, sl).field, "structured_light.projector_probe.step_s");
  const shorter = "structured_light.projector_probe.max_delay_s (0.01 s) is shorter than structured_light.projector_probe.step_s (0.02 s)";
  assert.equal(fieldError(shorter, sl).field, "structured_light.projector_probe.max_delay_s");
  const corners = "calibration.board_columns is 2 inner corners; use 3 to 100";
  assert.equal(fieldError(corners, calibration).field, "calibration.board_columns");
  const refresh = "structured_light.round_exposures_to_refresh: the projector does not report its display's refresh rate";
  assert.equal(fieldError(refresh, sl).field, "structured_light.round_exposures_to_refresh");
});

test("a plan-level message is placed by what it says", () => {
  const travel = "bracketed_stereo: 2 views 400 mm apart from 0 mm end at 400 mm, beyond the stage travel of 150 mm";
  assert.equal(fieldError(travel, stereo).field, "bracketed_stereo.baseline_mm");
  const both = "bracketed_stereo: give exposures_s or auto_bracket, not both (automatic bracketing chooses the exposures)";
  assert.equal(fieldError(both, stereo).field, "bracketed_stereo.exposures_s");
  const steps = "structured_light.projector_probe: 5 s in steps of 0.01 s are more than 100 frames; use a larger step_s or a smaller max_delay_s";
  assert.equal(fieldError(steps, sl).field, "structured_light.projector_probe.step_s");
});

test("session names", () => {
  assert.equal(fieldError("session is empty", stereo).field, "session");
  const bad = "session \"a b\" contains ' '; use only letters, digits, '-' and '_'";
  assert.equal(fieldError(bad, stereo).field, "session");
  assert.equal(fieldError("no session named \"nope\"", stereo).field, "session");
});

test("a field the form does not show, or no field, goes to the top", () => {
  const m = "plan must be one of bracketed_stereo, structured_light, calibration";
  assert.deepEqual(fieldError(m, stereo), { message: m });
  assert.equal(fieldError("no camera: not connected", stereo).field, undefined);
  assert.equal(fieldError("plan is required", stereo).field, undefined);
  // A calibration message while the stereo form is shown.
  assert.equal(fieldError("calibration.poses is 0; use 1 to 64", stereo).field, undefined);
  // A prefix of a known field's name is not that field.
  assert.equal(fieldError("bracketed_stereo.exposures is 1", stereo).field, undefined);
});
