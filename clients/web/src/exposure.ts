// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exposure times, the one place the console writes and reads them. Written
// as cameras show them: a fraction "1/125 s" below 0.3 s, seconds from
// there ("0.3 s", "2 s"). Read from what an operator types: "1/125",
// "1/125 s", "0.5", "2s", and lists of those ("1/60, 1/250 0.5").

const kFractionBelowS = 0.3;

export interface ExposureFormat {
  // For an input field: no unit, and only what reads back as the same
  // value (a fraction only when exactly one, else up to 6 digits); "" for
  // none.
  forInput?: boolean;
}

export function formatExposure(seconds: number, { forInput = false }: ExposureFormat = {}): string {
  if (!Number.isFinite(seconds) || seconds <= 0) return forInput ? "" : "–";
  const over = Math.round(1 / seconds);
  if (forInput) {
    const exact = seconds < kFractionBelowS && Math.abs(1 / over - seconds) <= seconds * 1e-9;
    return exact ? `1/${over}` : String(Number(seconds.toPrecision(6)));
  }
  if (seconds < kFractionBelowS) return `1/${over} s`;
  return `${Number(seconds.toPrecision(3))} s`;
}

// Seconds from "1/125", "1/125 s", "0.5", "2s", "1e-3"; undefined unless a
// positive number.
export function parseExposure(text: string): number | undefined {
  const t = text.trim().replace(/\s*s$/i, "");
  const fraction = /^(\d+(?:\.\d+)?)\s*\/\s*(\d+(?:\.\d+)?)$/.exec(t);
  const value = fraction ? Number(fraction[1]) / Number(fraction[2])
    : /^\d*\.?\d+(?:e[-+]?\d+)?$/i.test(t) ? Number(t) : NaN;
  return Number.isFinite(value) && value > 0 ? value : undefined;
}

export interface ExposureListError {
  index: number;  // of the item in the list, from 0
  message: string;
}

// A list separated by commas, semicolons or spaces ("1/60, 1/250 0.5",
// "1/60 s; 2 s"); empty: []. Every item that is not an exposure time is
// named in `errors`, its place in `values` NaN.
export function parseExposureList(text: string): { values: number[]; errors: ExposureListError[] } {
  const values: number[] = [];
  const errors: ExposureListError[] = [];
  // A space before a lone "s" is the unit's, not a separator.
  text.split(/[,;]|\s+(?!\s|s\b)/i).map((t) => t.trim()).filter((t) => t !== "").forEach((item, index) => {
    const value = parseExposure(item);
    if (value === undefined) {
      errors.push({ index, message: `"${item}" is not an exposure time; write seconds, e.g. 1/60 or 0.5` });
    }
    values.push(value ?? NaN);
  });
  return { values, errors };
}
