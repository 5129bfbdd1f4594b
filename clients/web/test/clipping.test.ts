// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { clipMask, countClipped, kClippedHigh, kClippedLow, paintOverlay } from "../src/clipping";

const kMagenta = [255, 0, 255, 255];
const kCyan = [0, 255, 255, 255];

const pixel = (rgba: Uint8ClampedArray, p: number) => Array.from(rgba.subarray(p * 4, p * 4 + 4));

test("a pixel is clipped high with any channel at 255 and low with any at 0", () => {
  const mask = clipMask([
    255, 10, 10, 255,    // high
    0, 0, 0, 255,        // low
    255, 0, 5, 255,      // both
    128, 128, 128, 0,    // neither
    254, 1, 1, 255,      // neither: the thresholds are exactly 255 and 0
  ]);
  assert.deepEqual(Array.from(mask), [kClippedHigh, kClippedLow, kClippedHigh | kClippedLow, 0, 0]);
  assert.deepEqual(countClipped(mask), { high: 2, low: 2 });
});

test("the overlay hatches clipped high in magenta and fills clipped low in cyan", () => {
  // 2 x 2: (0,0) high, (1,0) low, (0,1) both, (1,1) neither.
  const out = paintOverlay(Uint8Array.from([1, 2, 3, 0]), 2);
  assert.deepEqual(pixel(out, 0), kMagenta);
  assert.deepEqual(pixel(out, 1), kCyan);
  assert.deepEqual(pixel(out, 2), kMagenta);  // on a stripe: the high mark wins
  assert.equal(out[15], 0);                   // transparent
});

test("the hatching leaves the image visible between the stripes", () => {
  // One row of 6 clipped-high pixels: stripes at x + y mod 6 < 3.
  const out = paintOverlay(new Uint8Array(6).fill(kClippedHigh), 6);
  assert.deepEqual([0, 1, 2, 3, 4, 5].map((p) => out[p * 4 + 3]), [255, 255, 255, 0, 0, 0]);
  // The second row's stripe is shifted by one.
  const two = paintOverlay(new Uint8Array(12).fill(kClippedHigh), 6);
  assert.deepEqual([6, 7, 8, 9, 10, 11].map((p) => two[p * 4 + 3]), [255, 255, 0, 0, 0, 255]);
  // A pixel both high and low between stripes shows the low mark.
  const both = paintOverlay(Uint8Array.from([0, 0, 0, 0, 3, 0]), 6);
  assert.deepEqual(pixel(both, 4), kCyan);
});

test("a reused overlay buffer is cleared where nothing is clipped any more", () => {
  const out = paintOverlay(Uint8Array.from([1]), 1);
  assert.equal(out[3], 255);
  paintOverlay(Uint8Array.from([0]), 1, out);
  assert.equal(out[3], 0);
});
