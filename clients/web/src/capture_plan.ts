// SPDX-License-Identifier: GPL-3.0-or-later
//
// The capture form's values (text as typed, keyed by the field's path in
// the plan, the same path the daemon's messages name) made into a
// CapturePlan. Empty numbers are 0, which the daemon reads as its default;
// the daemon judges ranges (Jobs.EstimateCapture while the operator types),
// this only reads what was typed.
import { create } from "@bufbuild/protobuf";
import { ImageFormat } from "../gen/hdrstereo/v1/common_pb";
import { type CapturePlan, CapturePlanSchema } from "../gen/hdrstereo/v1/jobs_pb";
import { parseExposureList } from "./exposure";
import type { FieldError } from "./plan_field_errors";

export type PlanKind = "bracketed_stereo" | "structured_light" | "calibration";

// Text fields and check boxes of each plan, by path.
export const kPlanFields: Record<PlanKind, readonly string[]> = {
  bracketed_stereo: [
    "exposures_s", "auto_bracket", "auto_bracket.min_snr", "auto_bracket.max_step_stops",
    "auto_bracket.exclude_emitters_above", "auto_bracket.max_uncovered_fraction",
    "auto_bracket.max_exposure_s", "iso", "aperture_f", "format", "baseline_mm", "views",
    "settle_s", "skip_ambient",
  ].map((f) => `bracketed_stereo.${f}`),
  structured_light: [
    "exposures_s", "baseline_mm", "views", "settle_s", "iso", "aperture_f", "projector_probe",
    "projector_probe.step_s", "projector_probe.max_delay_s", "projector_probe.exposure_s",
    "round_exposures_to_refresh",
  ].map((f) => `structured_light.${f}`),
  calibration: [
    "poses", "exposure_s", "baseline_mm", "board_columns", "board_rows", "board_square_mm",
  ].map((f) => `calibration.${f}`),
};

export type FormValues = Record<string, string | boolean | undefined>;

// A number or a fraction ("1/60"); "" is 0. NaN when it is neither.
export function parseNumber(text: string): number {
  const t = text.trim();
  if (t === "") return 0;
  const fraction = /^([0-9.eE+-]+)\s*\/\s*([0-9.eE+-]+)$/.exec(t);
  const value = fraction ? Number(fraction[1]) / Number(fraction[2]) : Number(t);
  return Number.isFinite(value) ? value : NaN;
}

export function buildPlan(kind: PlanKind, values: FormValues): { plan: CapturePlan; errors: FieldError[] } {
  const errors: FieldError[] = [];
  const text = (f: string) => {
    const v = values[`${kind}.${f}`];
    return typeof v === "string" ? v : "";
  };
  const flag = (f: string) => values[`${kind}.${f}`] === true;
  const num = (f: string, integer = false) => {
    const field = `${kind}.${f}`;
    const v = parseNumber(text(f));
    if (Number.isNaN(v) || (integer && !Number.isInteger(v))) {
      errors.push({ field, message: `${field} is "${text(f).trim()}"; give ${integer ? "a whole number" : "a number"}` });
      return 0;
    }
    return v;
  };
  const exposures = () => {
    const field = `${kind}.exposures_s`;
    const parsed = parseExposureList(text("exposures_s"));
    errors.push(...parsed.errors.map((e) => ({ field, index: e.index, message: `${field}[${e.index}]: ${e.message}` })));
    return parsed.values.map((v) => (Number.isNaN(v) ? 0 : v));
  };
  let plan: CapturePlan;
  switch (kind) {
    case "bracketed_stereo": {
      const auto = flag("auto_bracket");
      plan = create(CapturePlanSchema, { plan: { case: "bracketedStereo", value: {
        exposuresS: auto ? [] : exposures(),
        iso: num("iso", true),
        apertureF: num("aperture_f"),
        format: Number(text("format") || ImageFormat.UNSPECIFIED) as ImageFormat,
        baselineMm: num("baseline_mm"),
        views: num("views", true),
        settleS: num("settle_s"),
        skipAmbient: flag("skip_ambient"),
        autoBracket: auto ? {
          minSnr: num("auto_bracket.min_snr"),
          maxStepStops: num("auto_bracket.max_step_stops"),
          excludeEmittersAbove: num("auto_bracket.exclude_emitters_above"),
          maxUncoveredFraction: num("auto_bracket.max_uncovered_fraction"),
          maxExposureS: num("auto_bracket.max_exposure_s"),
        } : undefined,
      } } });
      break;
    }
    case "structured_light":
      plan = create(CapturePlanSchema, { plan: { case: "structuredLight", value: {
        exposuresS: exposures(),
        baselineMm: num("baseline_mm"),
        views: num("views", true),
        settleS: num("settle_s"),
        iso: num("iso", true),
        apertureF: num("aperture_f"),
        projectorProbe: flag("projector_probe") ? {
          stepS: num("projector_probe.step_s"),
          maxDelayS: num("projector_probe.max_delay_s"),
          exposureS: num("projector_probe.exposure_s"),
        } : undefined,
        roundExposuresToRefresh: flag("round_exposures_to_refresh"),
      } } });
      break;
    case "calibration":
      plan = create(CapturePlanSchema, { plan: { case: "calibration", value: {
        poses: num("poses", true),
        exposureS: num("exposure_s"),
        baselineMm: num("baseline_mm"),
        boardColumns: num("board_columns", true),
        boardRows: num("board_rows", true),
        boardSquareMm: num("board_square_mm"),
      } } });
      break;
  }
  return { plan, errors };
}
