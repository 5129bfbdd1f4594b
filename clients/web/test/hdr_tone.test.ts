// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { autoExposureEv, drawSize, srgbEncode, toneByte, toneInto } from "../src/hdr_tone";

test("the sRGB curve at known points", () => {
  assert.equal(srgbEncode(0), 0);
  assert.equal(srgbEncode(-1), 0);
  assert.equal(srgbEncode(NaN), 0);
  assert.equal(srgbEncode(1), 1);
  assert.equal(srgbEncode(4), 1);
  assert.ok(Math.abs(srgbEncode(0.0031308) - 0.04045) < 1e-5);  // the two pieces meet
  assert.ok(Math.abs(srgbEncode(0.18) - 0.46135) < 1e-4);       // mid grey
  assert.ok(Math.abs(srgbEncode(0.5) - 0.73536) < 1e-4);
});

test("exposure doubles the radiance per EV before the curve", () => {
  assert.equal(toneByte(0.25, 2), 255);  // 0.25 * 4 = 1: white
  assert.equal(toneByte(0.5, -1), toneByte(0.25, 0));
  assert.equal(toneByte(0.18, 0), 118);  // 255 * 0.46135 = 117.6
  assert.equal(toneByte(0.09, 1), 118);
  assert.equal(toneByte(1e9, 0), 255);
});

test("toneInto follows toneByte within one code (its table has 4096 steps)", () => {
  const values = [0.01, 0.2, 0.7, 0.0001, 3, -1];
  const out = new Uint8ClampedArray(8);
  toneInto(new Float32Array(values), 3, { width: 2, height: 1 }, 0.5, out);
  values.forEach((v, i) => {
    const o = i < 3 ? i : 4 + (i - 3);
    assert.ok(Math.abs(out[o] - toneByte(v, 0.5)) <= 1, `value ${v}: ${out[o]} vs ${toneByte(v, 0.5)}`);
  });
  assert.equal(out[3], 255);
  assert.equal(out[7], 255);
  const grey = new Uint8ClampedArray(4);
  toneInto(new Float32Array([0.25]), 1, { width: 1, height: 1 }, 2, grey);
  assert.deepEqual([...grey], [255, 255, 255, 255]);
});

test("toneInto draws a smaller canvas from the map's pixel under each", () => {
  // A 4x2 grey map (rows from the top) drawn at 2x1: pixel centres 0.5 and
  // 1.5 land on map x 1 and 3 of row 1.
  const map = new Float32Array([0, 0.01, 0, 0.02, 0, 0.25, 0, 1]);
  const out = new Uint8ClampedArray(8);
  toneInto(map, 1, { width: 4, height: 2 }, 0, out, { width: 2, height: 1 });
  assert.deepEqual([...out], [137, 137, 137, 255, 255, 255, 255, 255]);
});

test("auto exposure puts the 99th percentile of luminance at white", () => {
  // Grey values 1..100: the 99th percentile is 100, so EV = -log2(100).
  const data = new Float32Array(100).map((_, i) => i + 1);
  assert.equal(autoExposureEv(data, 1), -6.6);
  // RGB of equal channels has the same luminance.
  const rgb = new Float32Array(300).map((_, i) => Math.floor(i / 3) + 1);
  assert.equal(autoExposureEv(rgb, 3), -6.6);
  assert.equal(autoExposureEv(new Float32Array([0, NaN, -1]), 1), 0);
  assert.equal(autoExposureEv(new Float32Array([0.25]), 1), 2);
});

test("the drawing buffer follows the shown size, at most the map's", () => {
  assert.deepEqual(drawSize(1200, 900, 725, 1), { width: 725, height: 544 });
  assert.deepEqual(drawSize(1200, 900, 725, 2), { width: 1200, height: 900 });
  assert.deepEqual(drawSize(1200, 900, 400.4, 1.5), { width: 601, height: 451 });
  assert.deepEqual(drawSize(1200, 900, 0, 1), { width: 1, height: 1 });
});
