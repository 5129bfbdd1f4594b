// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { histogramPath, levelAtRank, percentileRank, rgbaStatistics, summarize } from "../src/histogram";

test("percentile ranks are ceil(q n) in integers, at least 1", () => {
  assert.equal(percentileRank(1, 300), 3);
  assert.equal(percentileRank(1, 50), 1);
  assert.equal(percentileRank(50, 5), 3);
  assert.equal(percentileRank(99, 100), 99);
  assert.equal(percentileRank(99, 101), 100);
  assert.equal(percentileRank(1, 0), 1);
});

test("levelAtRank finds the lowest level reaching the rank", () => {
  const h = [2, 0, 3, 1];
  assert.equal(levelAtRank(h, 1), 0);
  assert.equal(levelAtRank(h, 2), 0);
  assert.equal(levelAtRank(h, 3), 2);
  assert.equal(levelAtRank(h, 6), 3);
  assert.equal(levelAtRank(h, 7), 3);  // beyond the pixels: the top level
});

test("percentiles of one pixel at each level 0..99", () => {
  const h = new Array(256).fill(0);
  for (let v = 0; v < 100; ++v) h[v] = 1;
  const s = summarize("gray", h);
  assert.deepEqual([s.p1, s.p50, s.p99], [0, 49, 98]);
  assert.equal(s.mean, 49.5);
  assert.equal(s.clippedLow, 0.01);
  assert.equal(s.clippedHigh, 0);
});

test("red, green and blue statistics of four RGBA pixels", () => {
  const rgba = [
    0, 10, 255, 255,
    0, 20, 255, 255,
    100, 20, 255, 0,  // alpha is ignored
    255, 30, 128, 255,
  ];
  const [red, green, blue] = rgbaStatistics(rgba);
  assert.equal(red.channel, "red");
  assert.equal(red.histogram.length, 256);
  assert.deepEqual([red.histogram[0], red.histogram[100], red.histogram[255]], [2, 1, 1]);
  assert.equal(red.histogram.reduce((a, b) => a + b), 4);
  assert.deepEqual([red.clippedLow, red.clippedHigh, red.mean], [0.5, 0.25, 88.75]);
  assert.deepEqual([red.p1, red.p50, red.p99], [0, 0, 255]);
  assert.equal(green.channel, "green");
  assert.deepEqual([green.clippedLow, green.clippedHigh, green.mean], [0, 0, 20]);
  assert.deepEqual([green.p1, green.p50, green.p99], [10, 20, 30]);
  assert.equal(blue.channel, "blue");
  assert.deepEqual([blue.histogram[128], blue.histogram[255]], [1, 3]);
  assert.deepEqual([blue.clippedLow, blue.clippedHigh, blue.mean], [0, 0.75, 223.25]);
  assert.deepEqual([blue.p1, blue.p50, blue.p99], [128, 255, 255]);
});

test("an empty histogram summarizes to zeros", () => {
  const s = summarize("red", new Array(256).fill(0));
  assert.deepEqual([s.mean, s.p1, s.p50, s.p99, s.clippedLow, s.clippedHigh], [0, 0, 0, 0, 0, 0]);
});

test("the histogram path is on a log scale", () => {
  // max 3: bin 1 (count 1) is log(2)/log(4) = half the height.
  assert.equal(histogramPath([0, 1, 3], 10), "M0 10L0 10L1 10L1 5L2 5L2 0L3 0L3 10Z");
  assert.equal(histogramPath([0, 0], 8), "M0 8L0 8L1 8L1 8L2 8L2 8Z");
});
