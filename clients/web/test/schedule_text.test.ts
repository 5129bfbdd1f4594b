// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { create } from "@bufbuild/protobuf";
import { CapturePlanSchema } from "../gen/hdrstereo/v1/jobs_pb";
import { MissedRunPolicy, SchedulePlanSchema, ScheduleRun_Outcome }
  from "../gen/hdrstereo/v1/schedules_pb";
import { describeCapture, describeCron, describePlan, missedRunPolicyText, runOutcome }
  from "../src/schedule_text";

test("describeCron reads common shapes", () => {
  assert.equal(describeCron("30 2 * * *"), "every day at 02:30");
  assert.equal(describeCron("@daily"), "every day at 00:00");
  assert.equal(describeCron("0 22 * * 1-5"), "at 22:00 every Monday to Friday");
  assert.equal(describeCron("15 6 * * mon,WED,7"), "at 06:15 every Monday, Wednesday and Sunday");
  assert.equal(describeCron("@weekly"), "at 00:00 every Sunday");
  assert.equal(describeCron("0 3 1 * *"), "at 03:00 on day 1 of every month");
  assert.equal(describeCron("5 * * * *"), "every hour at minute 5");
  assert.equal(describeCron("*/15 * * * *"), "every 15 minutes");
  assert.equal(describeCron("* * * * *"), "every minute");
});

test("describeCron leaves other shapes to the expression", () => {
  assert.equal(describeCron("0 0 1 1 *"), undefined);         // a month named
  assert.equal(describeCron("0 8-18/2 * * *"), undefined);    // hour steps
  assert.equal(describeCron("0 3 13 * 5"), undefined);        // day and weekday
  assert.equal(describeCron("0 3 * *"), undefined);           // 4 fields
  assert.equal(describeCron("61 3 * * *"), undefined);
});

test("describeCapture says what a capture takes", () => {
  const stereo = create(CapturePlanSchema, {
    plan: { case: "bracketedStereo", value: { exposuresS: [1 / 1000, 1 / 60, 1 / 250], baselineMm: 60 } },
  });
  assert.equal(describeCapture(stereo),
               "bracketed stereo: 3 exposures (1/1000 s to 1/60 s), 2 views 60 mm apart");
  const auto = create(CapturePlanSchema, {
    plan: { case: "bracketedStereo", value: { autoBracket: {}, views: 3 } },
  });
  assert.equal(describeCapture(auto), "bracketed stereo: automatic bracketing, 3 views");
  const light = create(CapturePlanSchema, {
    plan: { case: "structuredLight", value: { projectorProbe: {} } },
  });
  assert.equal(describeCapture(light),
               "structured light: the 2 default exposures, 2 views, projector probed");
});

test("describePlan lists session, captures and processing", () => {
  const plan = create(SchedulePlanSchema, {
    captures: [{ plan: { case: "bracketedStereo", value: { exposuresS: [0.5] } } }],
    processingSteps: ["hdr", "stereo"],
  });
  assert.deepEqual(describePlan(plan, "nightly"), [
    "session nightly-{date}-{time}",
    "bracketed stereo: 1 exposure (0.5 s), 2 views",
    "then processing: hdr, stereo",
  ]);
  plan.sessionPattern = "lab-{date}";
  plan.processingSteps = [];
  assert.equal(describePlan(plan, "nightly")[0], "session lab-{date}");
  assert.equal(describePlan(plan, "nightly")[2], "no processing");
});

test("runOutcome and missedRunPolicyText are words", () => {
  assert.deepEqual(runOutcome(ScheduleRun_Outcome.FAILED), { word: "failed", tone: "bad" });
  assert.deepEqual(runOutcome(ScheduleRun_Outcome.SKIPPED), { word: "skipped", tone: "warn" });
  assert.deepEqual(runOutcome(ScheduleRun_Outcome.SUCCEEDED), { word: "succeeded", tone: "ok" });
  assert.equal(missedRunPolicyText(MissedRunPolicy.SKIP), "missed runs are skipped");
  assert.equal(missedRunPolicyText(MissedRunPolicy.UNSPECIFIED), "a missed run runs once at start");
});
