// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { captureJobIn, retryDelayMs } from "../src/preview_retry";

test("the capture job a refusal names", () => {
  assert.equal(captureJobIn("the hardware is in use by a capture job: capture job 12 " +
                            "(session lab); wait for it or cancel it"), 12n);
  assert.equal(captureJobIn("locked by bob until 14:05: re-aligning"), undefined);
});

test("retries back off from 1 s to at most 15 s", () => {
  assert.deepEqual([0, 1, 2, 3, 4, 5, 9].map(retryDelayMs), [1000, 1000, 2000, 4000, 8000, 15000, 15000]);
});
