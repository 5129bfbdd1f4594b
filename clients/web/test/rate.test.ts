// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { RateMeter } from "../src/rate";

test("events 100 ms apart are 10 per second", () => {
  const m = new RateMeter(3000);
  for (let t = 0; t <= 2900; t += 100) m.record(t);
  assert.equal(m.rate(2950), 10);
  // At 3050 ms the event at 0 has left the window: 28 gaps over 2800 ms.
  assert.equal(m.rate(3050), 10);
  // A stall: more than 1.5 s (at least; twice the mean interval is less)
  // without an event.
  assert.equal(m.rate(4400), 10);
  assert.equal(m.rate(4401), 0);
  assert.equal(m.rate(9000), 0);  // all left: no rate
});

test("an uneven rate over the window", () => {
  const m = new RateMeter(3000);
  for (const t of [0, 500, 1000]) m.record(t);
  assert.equal(m.rate(1000), 2);
  assert.equal(m.rate(2000), 2);  // 1 s since the last: under the 1.5 s floor
  assert.equal(m.rate(2600), 0);  // 1.6 s: stalled
  assert.equal(new RateMeter().rate(0), 0);
});
