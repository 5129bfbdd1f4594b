// SPDX-License-Identifier: GPL-3.0-or-later
//
// The admin page's values in words and back: a call's status code, an API
// key's state, a key's lifetime from the form, the form's local times as
// timestamps, a webhook delivery's state.
import { timestampFromMs, type Timestamp } from "@bufbuild/protobuf/wkt";
import type { Tone } from "./schedule_text";

// google.rpc.Code, as the audit log records it.
const kCodeNames = [
  "OK", "cancelled", "unknown", "invalid argument", "deadline exceeded", "not found",
  "already exists", "permission denied", "resource exhausted", "failed precondition",
  "aborted", "out of range", "unimplemented", "internal", "unavailable", "data loss",
  "unauthenticated",
];

// An audited call's outcome in words: refusals (credentials, role, rig
// lock) are warnings, other failures errors.
export function callOutcome(code: number): { word: string; tone: Tone } {
  const word = kCodeNames[code] ?? `code ${code}`;
  if (code === 0) return { word, tone: "ok" };
  const refused = code === 7 || code === 16 || code === 9;
  return { word, tone: refused ? "warn" : "bad" };
}

const kMs = (t?: Timestamp) => (t ? Number(t.seconds) * 1000 + Math.round(t.nanos / 1e6) : undefined);

// A key is revoked, expired or active at `nowMs`.
export function keyState(key: { expireTime?: Timestamp; revokeTime?: Timestamp },
                         nowMs: number): { word: string; tone: Tone } {
  if (key.revokeTime) return { word: "revoked", tone: "bad" };
  const expires = kMs(key.expireTime);
  if (expires !== undefined && expires <= nowMs) return { word: "expired", tone: "idle" };
  return { word: "active", tone: "ok" };
}

export type TtlUnit = "hours" | "days";
export const kMaxTtlS = 366 * 86400;

// A key's lifetime from the form: a whole positive number of hours or
// days, at most 366 days (the daemon's limit). Throws saying why not.
export function ttlSeconds(amount: string, unit: TtlUnit): bigint {
  if (!/^\d+$/.test(amount.trim()) || Number(amount) <= 0) {
    throw new Error(`"${amount}" is not a whole number of ${unit} above 0`);
  }
  const seconds = Number(amount) * (unit === "hours" ? 3600 : 86400);
  if (seconds > kMaxTtlS) throw new Error("a key lasts at most 366 days");
  return BigInt(seconds);
}

// A datetime-local input's value ("2026-12-05T14:30", the browser's time
// zone) as a Timestamp; undefined when empty. Throws when unreadable.
export function localTimeToTimestamp(value: string): Timestamp | undefined {
  if (value.trim() === "") return undefined;
  const m = /^(\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2})(?::(\d{2}))?$/.exec(value.trim());
  if (!m) throw new Error(`"${value}" is not a date and time`);
  const [, y, mo, d, h, mi, s] = m.map(Number);
  const ms = new Date(y, mo - 1, d, h, mi, Number.isNaN(s) ? 0 : s).getTime();
  return timestampFromMs(ms);
}

// A webhook delivery's event state in words.
export function deliveryState(state: string): { word: string; tone: Tone } {
  switch (state) {
    case "delivered": return { word: "delivered", tone: "ok" };
    case "pending": return { word: "pending: will retry", tone: "warn" };
    case "abandoned": return { word: "abandoned", tone: "bad" };
    default: return { word: state || "unknown", tone: "idle" };
  }
}

// Event types a webhook can ask for (Webhook.events in admin.proto).
export const kWebhookEvents = [
  "job.*", "job.succeeded", "job.failed", "job.cancelled", "job.suspended", "job.resumed",
  "schedule_run.*", "schedule_run.succeeded", "schedule_run.failed", "schedule_run.skipped",
];

// The events to send for the ticked boxes: a family ("job.*") replaces
// its members, so the list says what the admin meant.
export function webhookEventFilter(ticked: readonly string[]): string[] {
  const families = ticked.filter((e) => e.endsWith(".*")).map((e) => e.slice(0, -1));
  return kWebhookEvents.filter((e) => ticked.includes(e) &&
    (e.endsWith(".*") || !families.some((f) => e.startsWith(f))));
}
