// SPDX-License-Identifier: GPL-3.0-or-later
//
// A running job's remaining time from its rate of progress: over the
// current running stretch (a pause or a wait restarts it, since the
// time it took says nothing about the rate), within the last `windowMs`.

export interface ProgressSample {
  timeMs: number;
  done: number;
  running: boolean;  // the job's state at the sample was RUNNING
}

// Seconds until `total` at the recent rate; undefined while the rate is
// not known (fewer than two running samples with progress between them).
export function remainingSeconds(samples: readonly ProgressSample[], total: number,
                                 windowMs = 120_000): number | undefined {
  let start = samples.length;
  while (start > 0 && samples[start - 1].running) --start;
  const run = samples.slice(start);
  if (run.length < 2) return undefined;
  const last = run[run.length - 1];
  if (last.done >= total) return 0;
  const first = run.find((s) => s.timeMs >= last.timeMs - windowMs) ?? run[0];
  const dt = (last.timeMs - first.timeMs) / 1000;
  const dd = last.done - first.done;
  if (dt <= 0 || dd <= 0) return undefined;
  return (total - last.done) * (dt / dd);
}
