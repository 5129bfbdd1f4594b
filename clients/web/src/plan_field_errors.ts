// SPDX-License-Identifier: GPL-3.0-or-later
//
// Which form field a server validation message names. The daemon words a
// bad plan by the field's path in the plan (daemon/jobs/capture_plan.cc,
// processing/base/options.h RequireField/WithFieldPrefix, store/names.cc):
//   "bracketed_stereo.exposures_s[2] is 0 s; exposures must be in (0, 3600] s"
//   "bracketed_stereo.auto_bracket.min_snr is 5; it must be in [10, 1000] ..."
//   "structured_light.projector_probe.max_delay_s (0.1 s) is shorter than ..."
//   "session \"a b\" contains ' '; use only letters, digits, '-' and '_'"
// A few name only the plan ("bracketed_stereo: 3 views 100 mm apart ...
// beyond the stage travel"): those are matched by what they say. The path
// itself is read as field_errors.ts reads it for every form.
import { fieldOf, messagePath } from "./field_errors";

export interface FieldError {
  field?: string;  // one of the form's fields; undefined: the form's top
  index?: number;  // the list entry named, e.g. exposures_s[2]
  message: string;
}

// Messages that name a plan (or nothing) but are about one field; $ is the
// plan's kind ("bracketed_stereo").
const kByWording: [RegExp, string][] = [
  [/^([a-z_]+): .*beyond the stage travel/, "$.baseline_mm"],
  [/^([a-z_]+): give exposures_s or auto_bracket, not both/, "$.exposures_s"],
  [/^([a-z_]+)\.projector_probe: .*use a larger step_s/, "$.projector_probe.step_s"],
  [/^no session named /, "session"],
];

// `fields`: the paths the form shows, e.g. "bracketed_stereo.exposures_s",
// "session".
export function fieldError(message: string, fields: readonly string[]): FieldError {
  for (const [pattern, target] of kByWording) {
    const m = pattern.exec(message);
    if (!m) continue;
    const field = target.replace("$", m[1] ?? "");
    if (fields.includes(field)) return { field, message };
  }
  const field = fieldOf(message, fields);
  if (field === undefined) return { message };
  const entry = /^\[(\d+)\]/.exec(messagePath(message)?.slice(field.length) ?? "");
  return entry ? { field, index: Number(entry[1]), message } : { field, message };
}
