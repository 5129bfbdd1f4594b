// SPDX-License-Identifier: GPL-3.0-or-later
//
// The new-schedule form's state and the Schedule it makes. Fields are named
// by the paths the daemon's validation messages use ("schedule.cron",
// "plan.captures[0].bracketed_stereo.views"), so a refused Create lands at
// the field it names (field_errors.ts) and so do the form's own checks.
import { create } from "@bufbuild/protobuf";
import { ImageFormat } from "../gen/hdrstereo/v1/common_pb";
import type { CapturePlan } from "../gen/hdrstereo/v1/jobs_pb";
import { MissedRunPolicy, type Schedule, ScheduleSchema } from "../gen/hdrstereo/v1/schedules_pb";
import { buildPlan, type FormValues } from "./capture_plan";

export type CaptureKind = "bracketed_stereo" | "structured_light";

// Text as typed; "" is the daemon's default for every number.
export interface CaptureDraft {
  kind: CaptureKind;
  exposures: string;
  autoBracket: boolean;   // bracketed stereo only
  views: string;
  baselineMm: string;
  settleS: string;
  iso: string;
  apertureF: string;
  format: ImageFormat;    // bracketed stereo only
  skipAmbient: boolean;   // bracketed stereo only
  projectorProbe: boolean;   // structured light only
  roundExposures: boolean;   // structured light only
}

export interface ScheduleDraft {
  name: string;
  cron: string;
  timeZone: string;
  enabled: boolean;
  missedRunPolicy: MissedRunPolicy;
  sessionPattern: string;
  captures: CaptureDraft[];
  processingSteps: string[];
}

export function newCapture(kind: CaptureKind): CaptureDraft {
  return {
    kind, exposures: "", autoBracket: false, views: "", baselineMm: "", settleS: "", iso: "",
    apertureF: "", format: ImageFormat.UNSPECIFIED, skipAmbient: false, projectorProbe: false,
    roundExposures: false,
  };
}

export function newScheduleDraft(timeZone: string): ScheduleDraft {
  return {
    name: "", cron: "0 2 * * *", timeZone, enabled: true,
    missedRunPolicy: MissedRunPolicy.RUN_ONCE_ON_START, sessionPattern: "",
    captures: [newCapture("bracketed_stereo")], processingSteps: [],
  };
}

export const capturePath = (i: number) => `plan.captures[${i}]`;
export const captureFieldPath = (i: number, kind: CaptureKind, field: string) =>
  `${capturePath(i)}.${kind}.${field}`;

const kCaptureFields: Record<CaptureKind, string[]> = {
  bracketed_stereo: ["exposures_s", "auto_bracket", "views", "baseline_mm", "settle_s", "iso",
                     "aperture_f", "format", "skip_ambient"],
  structured_light: ["exposures_s", "views", "baseline_mm", "settle_s", "iso", "aperture_f",
                     "projector_probe", "round_exposures_to_refresh"],
};

// Every field path the form shows for `draft`.
export function formFields(draft: ScheduleDraft): string[] {
  const fields = ["schedule.name", "schedule.cron", "schedule.time_zone", "schedule.enabled",
                  "schedule.missed_run_policy", "plan.session_pattern", "plan.captures",
                  "plan.processing_steps"];
  draft.captures.forEach((c, i) => {
    fields.push(capturePath(i), ...kCaptureFields[c.kind].map((f) => captureFieldPath(i, c.kind, f)));
  });
  return fields;
}

// One capture of the draft as the capture form's values, so that the
// capture form's builder (capture_plan.ts) makes it and reads its numbers.
function captureValues(c: CaptureDraft): FormValues {
  const k = c.kind;
  const values: FormValues = {
    [`${k}.exposures_s`]: c.exposures, [`${k}.views`]: c.views, [`${k}.baseline_mm`]: c.baselineMm,
    [`${k}.settle_s`]: c.settleS, [`${k}.iso`]: c.iso, [`${k}.aperture_f`]: c.apertureF,
  };
  if (k === "bracketed_stereo") {
    Object.assign(values, { [`${k}.auto_bracket`]: c.autoBracket, [`${k}.format`]: String(c.format),
                            [`${k}.skip_ambient`]: c.skipAmbient });
  } else {
    Object.assign(values, { [`${k}.projector_probe`]: c.projectorProbe,
                            [`${k}.round_exposures_to_refresh`]: c.roundExposures });
  }
  return values;
}

// The Schedule to create, or the form's own errors by field path (the
// first one of each field). Numbers are read as the capture form reads
// them; their ranges are the daemon's to judge.
export function buildSchedule(draft: ScheduleDraft):
    { schedule: Schedule; errors?: undefined } | { schedule?: undefined; errors: Record<string, string> } {
  const errors: Record<string, string> = {};
  const captures = draft.captures.map((c, i): CapturePlan => {
    const { plan, errors: found } = buildPlan(c.kind, captureValues(c));
    for (const e of found) {
      const path = e.field ? `${capturePath(i)}.${e.field}` : capturePath(i);
      errors[path] ??= e.message;
    }
    return plan;
  });
  if (draft.captures.length === 0) errors["plan.captures"] = "add at least one capture";
  if (Object.keys(errors).length > 0) return { errors };
  return {
    schedule: create(ScheduleSchema, {
      name: draft.name.trim(),
      cron: draft.cron.trim(),
      timeZone: draft.timeZone.trim(),
      enabled: draft.enabled,
      missedRunPolicy: draft.missedRunPolicy,
      plan: { sessionPattern: draft.sessionPattern.trim(), captures, processingSteps: draft.processingSteps },
    }),
  };
}
