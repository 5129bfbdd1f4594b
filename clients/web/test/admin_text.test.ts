// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { timestampFromMs } from "@bufbuild/protobuf/wkt";
import { callOutcome, deliveryState, keyState, localTimeToTimestamp, ttlSeconds,
         webhookEventFilter } from "../src/admin_text";

test("callOutcome names google.rpc codes", () => {
  assert.deepEqual(callOutcome(0), { word: "OK", tone: "ok" });
  assert.deepEqual(callOutcome(7), { word: "permission denied", tone: "warn" });
  assert.deepEqual(callOutcome(16), { word: "unauthenticated", tone: "warn" });
  assert.deepEqual(callOutcome(3), { word: "invalid argument", tone: "bad" });
  assert.deepEqual(callOutcome(42), { word: "code 42", tone: "bad" });
});

test("keyState: revoked before expired before active", () => {
  const now = 1_700_000_000_000;
  assert.equal(keyState({ expireTime: timestampFromMs(now + 1000) }, now).word, "active");
  assert.equal(keyState({ expireTime: timestampFromMs(now) }, now).word, "expired");
  assert.equal(keyState({ expireTime: timestampFromMs(now + 1000),
                          revokeTime: timestampFromMs(now - 5) }, now).word, "revoked");
});

test("ttlSeconds converts and bounds a lifetime", () => {
  assert.equal(ttlSeconds("30", "days"), 2_592_000n);
  assert.equal(ttlSeconds("12", "hours"), 43_200n);
  assert.equal(ttlSeconds("366", "days"), 31_622_400n);
  assert.throws(() => ttlSeconds("367", "days"), { message: "a key lasts at most 366 days" });
  assert.throws(() => ttlSeconds("0", "hours"),
                { message: "\"0\" is not a whole number of hours above 0" });
  assert.throws(() => ttlSeconds("1.5", "days"), /not a whole number of days/);
});

test("localTimeToTimestamp reads the browser's zone", () => {
  process.env.TZ = "Europe/Berlin";  // UTC+1 in December, UTC+2 in July
  assert.equal(localTimeToTimestamp("2026-12-05T04:30")?.seconds,
               BigInt(Date.UTC(2026, 11, 5, 3, 30) / 1000));
  assert.equal(localTimeToTimestamp("2026-07-01T12:00:30")?.seconds,
               BigInt(Date.UTC(2026, 6, 1, 10, 0, 30) / 1000));
  assert.equal(localTimeToTimestamp(""), undefined);
  assert.throws(() => localTimeToTimestamp("yesterday"), { message: "\"yesterday\" is not a date and time" });
});

test("deliveryState words", () => {
  assert.deepEqual(deliveryState("pending"), { word: "pending: will retry", tone: "warn" });
  assert.deepEqual(deliveryState("abandoned"), { word: "abandoned", tone: "bad" });
  assert.deepEqual(deliveryState(""), { word: "unknown", tone: "idle" });
});

test("webhookEventFilter lets a family replace its members", () => {
  assert.deepEqual(webhookEventFilter(["job.failed", "job.*", "schedule_run.failed"]),
                   ["job.*", "schedule_run.failed"]);
  assert.deepEqual(webhookEventFilter([]), []);
});
