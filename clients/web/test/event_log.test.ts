// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { gaps, lastSequence, mergeEvents, reconnectDelayMs } from "../src/event_log";

const ev = (sequence: number, message = `e${sequence}`) => ({ sequence: BigInt(sequence), message });
const seqs = (log: { sequence: bigint }[]) => log.map((e) => Number(e.sequence));

test("a resumed stream's repeats are dropped and the first copy kept", () => {
  const first = mergeEvents([], [ev(1), ev(2), ev(3)]);
  assert.deepEqual(seqs(first), [1, 2, 3]);
  const resumed = mergeEvents(first, [ev(3, "again"), ev(4), ev(5)]);
  assert.deepEqual(seqs(resumed), [1, 2, 3, 4, 5]);
  assert.equal(resumed[2].message, "e3");
  assert.equal(lastSequence(resumed), 5n);
});

test("nothing new gives the same log back", () => {
  const log = mergeEvents([], [ev(1), ev(2)]);
  assert.equal(mergeEvents(log, [ev(2), ev(1)]), log);
  assert.equal(mergeEvents(log, []), log);
});

test("out-of-order and late events take their place by sequence", () => {
  const log = mergeEvents([], [ev(1), ev(4), ev(2)]);
  assert.deepEqual(seqs(log), [1, 2, 4]);
  assert.deepEqual(gaps(log), [{ from: 3n, to: 3n }]);
  const filled = mergeEvents(log, [ev(3), ev(3), ev(5)]);
  assert.deepEqual(seqs(filled), [1, 2, 3, 4, 5]);
  assert.deepEqual(gaps(filled), []);
});

test("gaps are found from sequence 1 on", () => {
  assert.deepEqual(gaps([]), []);
  assert.deepEqual(gaps(mergeEvents([], [ev(3), ev(4), ev(9)])),
                   [{ from: 1n, to: 2n }, { from: 5n, to: 8n }]);
  assert.equal(lastSequence([]), 0n);
});

test("reconnection waits double from 0.5 s up to 10 s, jitter adds at most a quarter", () => {
  assert.deepEqual([0, 1, 2, 3, 4, 5, 9].map((a) => reconnectDelayMs(a)),
                   [500, 1000, 2000, 4000, 8000, 10000, 10000]);
  assert.equal(reconnectDelayMs(0, 0.999), 625);
  assert.equal(reconnectDelayMs(5, 0.5), 11250);
});
