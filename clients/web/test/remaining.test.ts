// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { remainingSeconds } from "../src/remaining";

const s = (t: number, done: number, running = true) => ({ timeMs: t * 1000, done, running });

test("the recent rate: 10 frames in 20 s leaves 40 frames for 80 s", () => {
  assert.equal(remainingSeconds([s(0, 0), s(10, 5), s(20, 10)], 50), 80);
});

test("a pause restarts the stretch the rate is taken over", () => {
  // 10 frames in 10 s, paused an hour, then 2 frames in 10 s: 8 left at 5 s each.
  const samples = [s(0, 0), s(10, 10), s(10, 10, false), s(3610, 10, false), s(3610, 10), s(3620, 12)];
  assert.equal(remainingSeconds(samples, 20), 40);
});

test("only the window counts: the last 60 s", () => {
  // Slow at first (1 frame in 100 s), then 6 frames in 60 s.
  const samples = [s(0, 0), s(100, 1), s(130, 4), s(160, 7)];
  assert.equal(remainingSeconds(samples, 17, 60_000), 100);
});

test("unknown without two samples or progress; zero when done", () => {
  assert.equal(remainingSeconds([], 10), undefined);
  assert.equal(remainingSeconds([s(0, 3)], 10), undefined);
  assert.equal(remainingSeconds([s(0, 3), s(5, 3)], 10), undefined);
  assert.equal(remainingSeconds([s(0, 3), s(5, 3, false)], 10), undefined);
  assert.equal(remainingSeconds([s(0, 9), s(5, 10)], 10), 0);
});
