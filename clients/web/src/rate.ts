// SPDX-License-Identifier: GPL-3.0-or-later
//
// Events per second over a sliding window: live view measures the frames
// the stream delivers and the frames it draws with one each.

export class RateMeter {
  private times: number[] = [];

  constructor(private readonly windowMs = 3000) {}

  // Records an event at `nowMs` (e.g. performance.now()).
  record(nowMs: number): void {
    this.times.push(nowMs);
    this.forget(nowMs);
  }

  // Events per second: (events - 1) over the span from the first to the
  // last event still in the window ending at `nowMs`; 0 with fewer than two,
  // and 0 once no event came for twice the mean interval (at least 1.5 s):
  // a stalled stream reads 0, not its last rate.
  rate(nowMs: number): number {
    this.forget(nowMs);
    const n = this.times.length;
    if (n < 2) return 0;
    const span = this.times[n - 1] - this.times[0];
    if (span <= 0) return 0;
    const stalledAfter = Math.max(1500, (2 * span) / (n - 1));
    return nowMs - this.times[n - 1] > stalledAfter ? 0 : ((n - 1) * 1000) / span;
  }

  private forget(nowMs: number): void {
    let drop = 0;
    while (drop < this.times.length && this.times[drop] <= nowMs - this.windowMs) ++drop;
    if (drop > 0) this.times.splice(0, drop);
  }
}
