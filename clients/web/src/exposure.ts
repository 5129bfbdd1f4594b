// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exposure times as photographers write them: "1/125 s" below 0.3 s,
// seconds above; and back from what an operator types ("1/125", "0.5",
// "2 s").

export function formatExposure(seconds: number): string {
  if (!Number.isFinite(seconds) || seconds <= 0) return "–";
  if (seconds < 0.3) return `1/${Math.round(1 / seconds)} s`;
  return `${Number(seconds.toPrecision(3))} s`;
}

// Seconds from "1/125", "1/125 s", "0.5", "2s"; undefined unless positive.
export function parseExposure(text: string): number | undefined {
  const t = text.trim().replace(/\s*s$/i, "").trim();
  const fraction = /^(\d+(?:\.\d+)?)\s*\/\s*(\d+(?:\.\d+)?)$/.exec(t);
  const value = fraction ? Number(fraction[1]) / Number(fraction[2])
                         : /^\d*\.?\d+(?:e-?\d+)?$/i.test(t) ? Number(t) : NaN;
  return Number.isFinite(value) && value > 0 ? value : undefined;
}
