// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { ImageFormat } from "../gen/hdrstereo/v1/common_pb";
import { MissedRunPolicy } from "../gen/hdrstereo/v1/schedules_pb";
import { fieldOf } from "../src/field_errors";
import { buildSchedule, formFields, newCapture, newScheduleDraft } from "../src/schedule_form";

test("buildSchedule makes the Schedule the form describes", () => {
  const draft = newScheduleDraft("Europe/Berlin");
  draft.name = " nightly ";
  draft.cron = "30 2 * * 1-5";
  draft.missedRunPolicy = MissedRunPolicy.SKIP;
  draft.sessionPattern = "night-{date}";
  draft.captures[0] = { ...draft.captures[0], exposures: "1/60, 1/250", views: "3",
                        baselineMm: "75.5", format: ImageFormat.TIFF_16, skipAmbient: true };
  draft.captures.push({ ...newCapture("structured_light"), projectorProbe: true });
  draft.processingSteps = ["stereo"];
  const { schedule, errors } = buildSchedule(draft);
  assert.equal(errors, undefined);
  assert.ok(schedule);
  assert.equal(schedule.name, "nightly");
  assert.equal(schedule.cron, "30 2 * * 1-5");
  assert.equal(schedule.timeZone, "Europe/Berlin");
  assert.equal(schedule.missedRunPolicy, MissedRunPolicy.SKIP);
  assert.equal(schedule.plan?.sessionPattern, "night-{date}");
  assert.deepEqual(schedule.plan?.processingSteps, ["stereo"]);
  const [stereo, light] = schedule.plan?.captures ?? [];
  assert.equal(stereo.plan.case, "bracketedStereo");
  if (stereo.plan.case === "bracketedStereo") {
    assert.deepEqual(stereo.plan.value.exposuresS, [1 / 60, 1 / 250]);
    assert.equal(stereo.plan.value.views, 3);
    assert.equal(stereo.plan.value.baselineMm, 75.5);
    assert.equal(stereo.plan.value.iso, 0);
    assert.equal(stereo.plan.value.format, ImageFormat.TIFF_16);
    assert.equal(stereo.plan.value.skipAmbient, true);
    assert.equal(stereo.plan.value.autoBracket, undefined);
  }
  assert.equal(light.plan.case, "structuredLight");
  if (light.plan.case === "structuredLight") {
    assert.deepEqual(light.plan.value.exposuresS, []);
    assert.ok(light.plan.value.projectorProbe);
    assert.equal(light.plan.value.roundExposuresToRefresh, false);
  }
});

test("automatic bracketing sends no exposures", () => {
  const draft = newScheduleDraft("");
  draft.captures[0] = { ...draft.captures[0], autoBracket: true, exposures: "not read" };
  const { schedule } = buildSchedule(draft);
  const plan = schedule?.plan?.captures[0].plan;
  assert.equal(plan?.case, "bracketedStereo");
  if (plan?.case === "bracketedStereo") {
    assert.deepEqual(plan.value.exposuresS, []);
    assert.ok(plan.value.autoBracket);
  }
});

test("buildSchedule's own errors sit at their fields", () => {
  const draft = newScheduleDraft("UTC");
  draft.captures.push(newCapture("structured_light"));
  draft.captures[0] = { ...draft.captures[0], views: "2.5" };
  draft.captures[1] = { ...draft.captures[1], exposures: "1/60 x", baselineMm: "3 mm" };
  assert.deepEqual(buildSchedule(draft).errors, {
    "plan.captures[0].bracketed_stereo.views": "bracketed_stereo.views is \"2.5\"; give a whole number",
    "plan.captures[1].structured_light.exposures_s":
      "structured_light.exposures_s[1]: \"x\" is not an exposure time; write seconds, e.g. 1/60 or 0.5",
    "plan.captures[1].structured_light.baseline_mm": "structured_light.baseline_mm is \"3 mm\"; give a number",
  });
  // Ranges are the daemon's to judge (its message lands at the field).
  draft.captures[0] = { ...draft.captures[0], views: "" };
  draft.captures[1] = { ...draft.captures[1], exposures: "1/60", baselineMm: "-3" };
  const { schedule } = buildSchedule(draft);
  const light = schedule?.plan?.captures[1].plan;
  assert.equal(light?.case === "structuredLight" && light.value.baselineMm, -3);
  draft.captures = [];
  assert.deepEqual(buildSchedule(draft).errors, { "plan.captures": "add at least one capture" });
});

test("the daemon's messages find the form's fields", () => {
  const draft = newScheduleDraft("UTC");
  draft.captures.push(newCapture("structured_light"));
  const fields = formFields(draft);
  assert.equal(fieldOf("plan.captures[1]: structured_light.settle_s is 99; use 0 to 60 s", fields),
               "plan.captures[1].structured_light.settle_s");
  assert.equal(fieldOf("plan.captures[0]: bracketed_stereo: 3 views 150 mm apart from 0 mm", fields),
               "plan.captures[0]");
  assert.equal(fieldOf("plan.processing_steps: unknown step \"x\"", fields), "plan.processing_steps");
  // A structured-light field is not on a bracketed-stereo capture.
  assert.equal(fieldOf("plan.captures[0]: structured_light.views is 0", fields), "plan.captures[0]");
});
