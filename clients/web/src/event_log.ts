// SPDX-License-Identifier: GPL-3.0-or-later
//
// A job's event log as the console keeps it across Watch streams: events
// merged by sequence (1, 2, 3, ... per job), so that a stream resumed with
// after_sequence after a dropped connection neither repeats nor loses one,
// and a gap (an event the streams never delivered) is seen, not hidden.

export interface Sequenced {
  sequence: bigint;
}

export interface Gap {
  from: bigint;  // first missing sequence
  to: bigint;    // last missing sequence
}

// `log` with `incoming` merged in, in sequence order; events already in
// the log are dropped (the first copy is kept). Returns `log` itself when
// nothing is new.
export function mergeEvents<E extends Sequenced>(log: readonly E[], incoming: readonly E[]): E[] {
  const last = lastSequence(log);
  const fresh = incoming.filter((e) => e.sequence > last);
  const older = incoming.filter((e) => e.sequence <= last);
  if (older.length === 0) {
    if (fresh.length === 0) return log as E[];
    // The common case: a stream appends in order.
    const sorted = dedupe([...fresh].sort(bySequence));
    return [...log, ...sorted];
  }
  const seen = new Set(log.map((e) => e.sequence));
  const added = incoming.filter((e) => !seen.has(e.sequence));
  if (added.length === 0) return log as E[];
  return dedupe([...log, ...added].sort(bySequence));
}

// The sequence to resume after (Jobs.Watch after_sequence): the last one
// held, 0 for none.
export function lastSequence(log: readonly Sequenced[]): bigint {
  return log.length === 0 ? 0n : log[log.length - 1].sequence;
}

// Sequences missing from a sorted log, from 1 up to its last event.
export function gaps(log: readonly Sequenced[]): Gap[] {
  const out: Gap[] = [];
  let expected = 1n;
  for (const e of log) {
    if (e.sequence > expected) out.push({ from: expected, to: e.sequence - 1n });
    expected = e.sequence + 1n;
  }
  return out;
}

function bySequence(a: Sequenced, b: Sequenced): number {
  return a.sequence < b.sequence ? -1 : a.sequence > b.sequence ? 1 : 0;
}

function dedupe<E extends Sequenced>(sorted: E[]): E[] {
  return sorted.filter((e, i) => i === 0 || e.sequence !== sorted[i - 1].sequence);
}

// Wait before the `attempt`th reconnection (0-based): 0.5 s doubling up to
// 10 s, so a restarting daemon is not hammered; `jitter` in [0, 1) spreads
// many pages apart by up to a quarter.
export function reconnectDelayMs(attempt: number, jitter = 0): number {
  const base = Math.min(500 * 2 ** Math.max(0, attempt), 10_000);
  return Math.round(base * (1 + jitter / 4));
}
