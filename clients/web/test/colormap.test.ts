// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import {
  colorize, colormapIndex, finiteRange, kInvalidRgb, kViridis, lightness, normalize, viridis,
} from "../src/colormap";

test("viridis has 256 entries with matplotlib's endpoints and middle", () => {
  assert.equal(kViridis.length, 768);
  assert.deepEqual(viridis(0), [0x44, 0x01, 0x54]);    // #440154
  assert.deepEqual(viridis(1), [0xfd, 0xe7, 0x25]);    // #fde725
  assert.deepEqual(viridis(0.5), [0x21, 0x91, 0x8c]);  // index 128: #21918c
});

test("viridis' lightness rises monotonically from end to end", () => {
  // The 8-bit table wobbles by a few hundredths of L* between neighbours
  // (95, 113, 130, 146); beyond that, and over every 4 entries, it rises.
  const l = Array.from({ length: 256 },
                       (_, i) => lightness([kViridis[3 * i], kViridis[3 * i + 1], kViridis[3 * i + 2]]));
  for (let i = 1; i < 256; ++i) {
    assert.ok(l[i] > l[i - 1] - 0.05, `L* falls at index ${i}: ${l[i]} after ${l[i - 1]}`);
  }
  for (let i = 4; i < 256; ++i) assert.ok(l[i] > l[i - 4] + 0.5, `L* flat at index ${i}`);
  assert.ok(l[0] < 20 && l[255] > 85, `L* from ${l[0]} to ${l[255]}`);
});

test("lightness of known colours", () => {
  assert.equal(lightness([0, 0, 0]), 0);
  assert.ok(Math.abs(lightness([255, 255, 255]) - 100) < 1e-9);
  assert.ok(Math.abs(lightness([128, 128, 128]) - 53.585) < 0.01);
});

test("the invalid grey is far from every viridis colour", () => {
  for (let i = 0; i < 256; ++i) {
    const d = Math.hypot(kViridis[3 * i] - kInvalidRgb[0], kViridis[3 * i + 1] - kInvalidRgb[1],
                         kViridis[3 * i + 2] - kInvalidRgb[2]);
    assert.ok(d > 60, `index ${i} is ${d.toFixed(1)} from the grey`);
  }
});

test("value to table index: clamped, 256 equal bins", () => {
  assert.equal(colormapIndex(-3), 0);
  assert.equal(colormapIndex(NaN), 0);
  assert.equal(colormapIndex(0), 0);
  assert.equal(colormapIndex(1 / 256 - 1e-9), 0);
  assert.equal(colormapIndex(1 / 256), 1);
  assert.equal(colormapIndex(0.5), 128);
  assert.equal(colormapIndex(0.999), 255);
  assert.equal(colormapIndex(1), 255);
  assert.equal(colormapIndex(7), 255);
  assert.equal(normalize(15, 10, 30), 0.25);
  assert.equal(normalize(5, 10, 30), 0);
  assert.equal(normalize(40, 10, 30), 1);
  assert.equal(normalize(3, 3, 3), 0);
});

test("finite range skips NaN and infinities and counts them", () => {
  const r = finiteRange(new Float32Array([4, NaN, -2, Infinity, 10, -Infinity]));
  assert.deepEqual(r, { min: -2, max: 10, finite: 3, total: 6 });
  assert.deepEqual(finiteRange(new Float32Array([NaN])), { min: 0, max: 0, finite: 0, total: 1 });
  // channel 1 of two-channel data
  assert.deepEqual(finiteRange(new Float32Array([100, 1, 200, 3]), 2, 1),
                   { min: 1, max: 3, finite: 2, total: 2 });
});

test("colorize paints ends of the range and invalid pixels", () => {
  const out = new Uint8ClampedArray(16);
  colorize(new Float32Array([10, 30, Infinity, 20]), 10, 30, out);
  assert.deepEqual([...out.slice(0, 4)], [0x44, 0x01, 0x54, 255]);
  assert.deepEqual([...out.slice(4, 8)], [0xfd, 0xe7, 0x25, 255]);
  assert.deepEqual([...out.slice(8, 12)], [128, 128, 128, 255]);
  assert.deepEqual([...out.slice(12, 16)], [0x21, 0x91, 0x8c, 255]);  // 0.5 → index 128
});
