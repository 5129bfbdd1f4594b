// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { formatExposure, parseExposure } from "../src/exposure";

test("exposure times are written as fractions below 0.3 s", () => {
  assert.equal(formatExposure(1 / 125), "1/125 s");
  assert.equal(formatExposure(0.25), "1/4 s");
  assert.equal(formatExposure(1 / 3), "0.333 s");
  assert.equal(formatExposure(0.5), "0.5 s");
  assert.equal(formatExposure(2), "2 s");
  assert.equal(formatExposure(0), "–");
});

test("exposure times are read as fractions or seconds", () => {
  assert.equal(parseExposure("1/125"), 0.008);
  assert.equal(parseExposure(" 1/125 s "), 0.008);
  assert.equal(parseExposure("0.5"), 0.5);
  assert.equal(parseExposure("2s"), 2);
  assert.equal(parseExposure(".25"), 0.25);
  assert.equal(parseExposure("abc"), undefined);
  assert.equal(parseExposure("0"), undefined);
  assert.equal(parseExposure("-1"), undefined);
  assert.equal(parseExposure("1/0"), undefined);
});
