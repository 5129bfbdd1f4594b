// SPDX-License-Identifier: GPL-3.0-or-later
//
// Schedules in words: a cron expression read out where it is a common
// shape, a plan as one line, a run's outcome.
import type { CapturePlan } from "../gen/hdrstereo/v1/jobs_pb";
import { MissedRunPolicy, type SchedulePlan, ScheduleRun_Outcome }
  from "../gen/hdrstereo/v1/schedules_pb";
import { formatExposure } from "./exposure";

const kDayNames = ["Sunday", "Monday", "Tuesday", "Wednesday", "Thursday", "Friday", "Saturday"];
const kDayAbbrev = ["SUN", "MON", "TUE", "WED", "THU", "FRI", "SAT"];

const kMacros: Record<string, string> = {
  "@yearly": "0 0 1 1 *", "@annually": "0 0 1 1 *", "@monthly": "0 0 1 * *",
  "@weekly": "0 0 * * 0", "@daily": "0 0 * * *", "@midnight": "0 0 * * *",
  "@hourly": "0 * * * *",
};

function whole(text: string, max: number): number | undefined {
  if (!/^\d{1,2}$/.test(text)) return undefined;
  const n = Number(text);
  return n <= max ? n : undefined;
}

function weekday(text: string): number | undefined {
  const named = kDayAbbrev.indexOf(text.toUpperCase());
  if (named >= 0) return named;
  const n = whole(text, 7);
  return n === undefined ? undefined : n % 7;
}

// "1-5" -> "Monday to Friday", "1,3,5" -> "Monday, Wednesday and Friday".
function weekdays(field: string): string | undefined {
  const names: string[] = [];
  for (const part of field.split(",")) {
    const range = part.split("-");
    if (range.length === 2) {
      const from = weekday(range[0]);
      const to = weekday(range[1]);
      if (from === undefined || to === undefined) return undefined;
      names.push(`${kDayNames[from]} to ${kDayNames[to]}`);
    } else {
      const day = weekday(part);
      if (day === undefined) return undefined;
      names.push(kDayNames[day]);
    }
  }
  if (names.length === 1) return names[0];
  return `${names.slice(0, -1).join(", ")} and ${names[names.length - 1]}`;
}

const pad2 = (n: number) => String(n).padStart(2, "0");

// A cron expression in words when it has a common shape (daily, on some
// weekdays, monthly, hourly, every N minutes); undefined otherwise, when
// the expression itself is the clearest description.
export function describeCron(cron: string): string | undefined {
  const expression = kMacros[cron.trim().toLowerCase()] ?? cron.trim();
  const fields = expression.split(/\s+/);
  if (fields.length !== 5) return undefined;
  const [minuteField, hourField, dayField, monthField, weekdayField] = fields;
  if (monthField !== "*") return undefined;
  const minute = whole(minuteField, 59);
  const hour = whole(hourField, 23);
  if (hourField === "*" && dayField === "*" && weekdayField === "*") {
    if (minute !== undefined) return `every hour at minute ${minute}`;
    const step = /^\*\/(\d{1,2})$/.exec(minuteField);
    if (step && Number(step[1]) > 0 && Number(step[1]) < 60) {
      return Number(step[1]) === 1 ? "every minute" : `every ${Number(step[1])} minutes`;
    }
    if (minuteField === "*") return "every minute";
    return undefined;
  }
  if (minute === undefined || hour === undefined) return undefined;
  const at = `at ${pad2(hour)}:${pad2(minute)}`;
  if (dayField === "*" && weekdayField === "*") return `every day ${at}`;
  if (dayField === "*") {
    const days = weekdays(weekdayField);
    return days === undefined ? undefined : `${at} every ${days}`;
  }
  const day = whole(dayField, 31);
  if (weekdayField === "*" && day !== undefined && day >= 1) {
    return `${at} on day ${day} of every month`;
  }
  return undefined;
}

function exposures(list: number[]): string {
  if (list.length === 1) return `1 exposure (${formatExposure(list[0])})`;
  const sorted = [...list].sort((a, b) => a - b);
  return `${list.length} exposures (${formatExposure(sorted[0])} to ${formatExposure(sorted[sorted.length - 1])})`;
}

function views(count: number, baselineMm: number): string {
  const n = count === 0 ? 2 : count;
  const apart = baselineMm > 0 ? ` ${Number(baselineMm.toPrecision(4))} mm apart` : "";
  return `${n} views${apart}`;
}

// One capture of a plan in a line.
export function describeCapture(capture: CapturePlan): string {
  const plan = capture.plan;
  switch (plan.case) {
    case "bracketedStereo": {
      const p = plan.value;
      const what = p.autoBracket ? "automatic bracketing"
        : p.exposuresS.length > 0 ? exposures(p.exposuresS) : "the 8 default exposures";
      return `bracketed stereo: ${what}, ${views(p.views, p.baselineMm)}`;
    }
    case "structuredLight": {
      const p = plan.value;
      const what = p.exposuresS.length > 0 ? exposures(p.exposuresS) : "the 2 default exposures";
      const probe = p.projectorProbe ? ", projector probed" : "";
      return `structured light: ${what}, ${views(p.views, p.baselineMm)}${probe}`;
    }
    case "calibration":
      return `calibration: ${plan.value.poses} poses`;
    default:
      return "an empty capture";
  }
}

// A plan as lines: its session name, each capture, the processing after.
export function describePlan(plan: SchedulePlan | undefined, schedule: string): string[] {
  const pattern = plan?.sessionPattern || `${schedule}-{date}-{time}`;
  const lines = [`session ${pattern}`];
  for (const capture of plan?.captures ?? []) lines.push(describeCapture(capture));
  const steps = plan?.processingSteps ?? [];
  lines.push(steps.length > 0 ? `then processing: ${steps.join(", ")}` : "no processing");
  return lines;
}

export type Tone = "ok" | "warn" | "bad" | "idle";

// A run's outcome in words, with the tone of its badge.
export function runOutcome(outcome: ScheduleRun_Outcome): { word: string; tone: Tone } {
  switch (outcome) {
    case ScheduleRun_Outcome.RUNNING: return { word: "running", tone: "idle" };
    case ScheduleRun_Outcome.SUCCEEDED: return { word: "succeeded", tone: "ok" };
    case ScheduleRun_Outcome.FAILED: return { word: "failed", tone: "bad" };
    case ScheduleRun_Outcome.SKIPPED: return { word: "skipped", tone: "warn" };
    default: return { word: "unknown", tone: "idle" };
  }
}

export function missedRunPolicyText(policy: MissedRunPolicy): string {
  return policy === MissedRunPolicy.SKIP ? "missed runs are skipped"
    : "a missed run runs once at start";
}
