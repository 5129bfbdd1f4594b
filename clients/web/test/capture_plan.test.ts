// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { buildPlan, parseNumber } from "../src/capture_plan";

test("numbers and fractions; empty is the daemon's default", () => {
  assert.equal(parseNumber(""), 0);
  assert.equal(parseNumber(" 2.5 "), 2.5);
  assert.equal(parseNumber("1/4"), 0.25);
  assert.ok(Number.isNaN(parseNumber("fast")));
  assert.ok(Number.isNaN(parseNumber("1/0")));
});

test("a bad entry of the exposure list is named at its field and index", () => {
  const { plan, errors } = buildPlan("structured_light", { "structured_light.exposures_s": "1/60,x" });
  assert.deepEqual(errors, [{
    field: "structured_light.exposures_s", index: 1,
    message: "structured_light.exposures_s[1]: \"x\" is not an exposure time; write seconds, e.g. 1/60 or 0.5",
  }]);
  if (plan.plan.case !== "structuredLight") assert.fail("not structured light");
  assert.deepEqual(plan.plan.value.exposuresS, [1 / 60, 0]);
});

test("a stereo form makes its plan; automatic bracketing leaves the exposures out", () => {
  const { plan, errors } = buildPlan("bracketed_stereo", {
    "bracketed_stereo.exposures_s": "1/2, 1/4",
    "bracketed_stereo.baseline_mm": "50",
    "bracketed_stereo.views": "3",
    "bracketed_stereo.skip_ambient": true,
  });
  assert.deepEqual(errors, []);
  assert.equal(plan.plan.case, "bracketedStereo");
  if (plan.plan.case !== "bracketedStereo") return;
  assert.deepEqual(plan.plan.value.exposuresS, [0.5, 0.25]);
  assert.equal(plan.plan.value.baselineMm, 50);
  assert.equal(plan.plan.value.views, 3);
  assert.equal(plan.plan.value.skipAmbient, true);
  assert.equal(plan.plan.value.autoBracket, undefined);
  const auto = buildPlan("bracketed_stereo", {
    "bracketed_stereo.exposures_s": "1/2", "bracketed_stereo.auto_bracket": true,
    "bracketed_stereo.auto_bracket.min_snr": "20",
  }).plan;
  if (auto.plan.case !== "bracketedStereo") assert.fail("not stereo");
  assert.deepEqual(auto.plan.value.exposuresS, []);
  assert.equal(auto.plan.value.autoBracket?.minSnr, 20);
});

test("the projector probe is set only when asked for, even with defaults", () => {
  const off = buildPlan("structured_light", {}).plan;
  if (off.plan.case !== "structuredLight") assert.fail("not structured light");
  assert.equal(off.plan.value.projectorProbe, undefined);
  const on = buildPlan("structured_light", { "structured_light.projector_probe": true }).plan;
  if (on.plan.case !== "structuredLight") assert.fail("not structured light");
  assert.equal(on.plan.value.projectorProbe?.stepS, 0);
});

test("a whole number is needed where the plan has an integer", () => {
  const { errors } = buildPlan("calibration", { "calibration.poses": "2.5" });
  assert.equal(errors.length, 1);
  assert.equal(errors[0].field, "calibration.poses");
});
