// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { formatExposure, parseExposure, parseExposureList } from "../src/exposure";

test("exposure times are written as fractions below 0.3 s, seconds from there", () => {
  assert.equal(formatExposure(1 / 125), "1/125 s");
  assert.equal(formatExposure(0.25), "1/4 s");
  assert.equal(formatExposure(1 / 3), "0.333 s");
  assert.equal(formatExposure(0.5), "0.5 s");
  assert.equal(formatExposure(2), "2 s");
  assert.equal(formatExposure(0), "–");
  assert.equal(formatExposure(-1), "–");
  assert.equal(formatExposure(NaN), "–");
  // From the former copies in results.ts and schedule_text.ts.
  assert.equal(formatExposure(0.004), "1/250 s");
  assert.equal(formatExposure(1 / 30), "1/30 s");
  assert.equal(formatExposure(1 / 60), "1/60 s");
  assert.equal(formatExposure(0.3), "0.3 s");
  // Not a unit fraction: the nearest one, as a camera shows it (1/243.9).
  assert.equal(formatExposure(0.0041), "1/244 s");
  assert.equal(formatExposure(12.345), "12.3 s");
});

test("for an input field: no unit, and text that reads back as the same value", () => {
  // The cases of the former capture_plan.ts copy.
  assert.equal(formatExposure(1 / 60, { forInput: true }), "1/60");
  assert.equal(formatExposure(0.5, { forInput: true }), "0.5");
  assert.equal(formatExposure(0.3, { forInput: true }), "0.3");
  assert.equal(formatExposure(2, { forInput: true }), "2");
  assert.equal(formatExposure(0.0041, { forInput: true }), "0.0041");
  assert.equal(formatExposure(1 / 3, { forInput: true }), "0.333333");
  assert.equal(formatExposure(0, { forInput: true }), "");
  for (const s of [1 / 8000, 1 / 60, 0.0041, 0.25, 1 / 3, 0.5, 2, 30]) {
    const back = parseExposure(formatExposure(s, { forInput: true }));
    assert.ok(back !== undefined && Math.abs(back - s) <= s * 1e-6, `${s} read back as ${back}`);
  }
});

test("exposure times are read as fractions or seconds", () => {
  assert.equal(parseExposure("1/125"), 0.008);
  assert.equal(parseExposure(" 1/125 s "), 0.008);
  assert.equal(parseExposure("0.5"), 0.5);
  assert.equal(parseExposure("2s"), 2);
  assert.equal(parseExposure(".25"), 0.25);
  assert.equal(parseExposure("1e-3"), 0.001);
  assert.equal(parseExposure("abc"), undefined);
  assert.equal(parseExposure(""), undefined);
  assert.equal(parseExposure("0"), undefined);
  assert.equal(parseExposure("-1"), undefined);
  assert.equal(parseExposure("1/0"), undefined);
});

test("exposure lists: commas, semicolons or spaces; every bad entry named", () => {
  // The cases of the former schedule_text.ts and capture_plan.ts parsers.
  assert.deepEqual(parseExposureList("1/4, 0.5 2"), { values: [0.25, 0.5, 2], errors: [] });
  assert.deepEqual(parseExposureList("1/2, 1/4 2").values, [0.5, 0.25, 2]);
  assert.deepEqual(parseExposureList("  "), { values: [], errors: [] });
  const bad = parseExposureList("1/60, fast");
  assert.deepEqual(bad.values, [1 / 60, NaN]);
  assert.deepEqual(bad.errors,
                   [{ index: 1, message: "\"fast\" is not an exposure time; write seconds, e.g. 1/60 or 0.5" }]);
  assert.deepEqual(parseExposureList("1/60,x").errors.map((e) => e.index), [1]);
  assert.equal(parseExposureList("0").errors[0].message,
               "\"0\" is not an exposure time; write seconds, e.g. 1/60 or 0.5");
  assert.equal(parseExposureList("1/0").errors[0].message,
               "\"1/0\" is not an exposure time; write seconds, e.g. 1/60 or 0.5");
  // A unit after a value belongs to it.
  assert.deepEqual(parseExposureList("1/60 s; 2 s,0.5s  1/8").values, [1 / 60, 2, 0.5, 0.125]);
  assert.deepEqual(parseExposureList("1/60  s").values, [1 / 60]);
});
