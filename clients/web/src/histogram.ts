// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exposure statistics of a decoded 8-bit frame, per channel, computed the
// way the daemon computes them (processing/exposure/frame_statistics.cc):
// a 256-bin histogram, the fractions of pixels at level 0 (clipped low) and
// 255 (clipped high), the mean, and the 1st/50th/99th percentiles by
// nearest rank. Live view computes them from the pixels the browser decoded
// and can show either these or the ones the daemon sent with the frame.

export const kLevels = 256;

export interface ChannelHistogram {
  channel: string;      // "red", "green", "blue" or "gray"
  histogram: number[];  // kLevels bins: pixels per level
  clippedLow: number;   // fraction of pixels at level 0
  clippedHigh: number;  // fraction of pixels at level 255
  mean: number;
  p1: number;
  p50: number;
  p99: number;
}

// ceil(percent/100 * n) as a 1-based rank, at least 1, in integers (as the
// daemon's Rank(): 1 % of 300 pixels is rank 3 exactly).
export function percentileRank(percent: number, n: number): number {
  return Math.max(1, Math.floor((percent * n + 99) / 100));
}

// The lowest level whose cumulative count reaches `rank`.
export function levelAtRank(histogram: ArrayLike<number>, rank: number): number {
  let seen = 0;
  for (let v = 0; v < histogram.length; ++v) {
    seen += histogram[v];
    if (seen >= rank) return v;
  }
  return histogram.length - 1;
}

// The statistics of one channel from its histogram.
export function summarize(channel: string, histogram: ArrayLike<number>): ChannelHistogram {
  let n = 0;
  let sum = 0;
  for (let v = 0; v < histogram.length; ++v) {
    n += histogram[v];
    sum += v * histogram[v];
  }
  const bins = Array.from(histogram);
  if (n === 0) {
    return { channel, histogram: bins, clippedLow: 0, clippedHigh: 0, mean: 0, p1: 0, p50: 0, p99: 0 };
  }
  return {
    channel,
    histogram: bins,
    clippedLow: histogram[0] / n,
    clippedHigh: histogram[kLevels - 1] / n,
    mean: sum / n,
    p1: levelAtRank(histogram, percentileRank(1, n)),
    p50: levelAtRank(histogram, percentileRank(50, n)),
    p99: levelAtRank(histogram, percentileRank(99, n)),
  };
}

// Red, green and blue statistics of RGBA pixels (a canvas's ImageData;
// alpha is ignored). The daemon decodes every preview JPEG as colour, so
// these are the channels it reports too.
export function rgbaStatistics(rgba: ArrayLike<number>): ChannelHistogram[] {
  const red = new Float64Array(kLevels);
  const green = new Float64Array(kLevels);
  const blue = new Float64Array(kLevels);
  for (let i = 0; i + 3 < rgba.length; i += 4) {
    ++red[rgba[i]];
    ++green[rgba[i + 1]];
    ++blue[rgba[i + 2]];
  }
  return [summarize("red", red), summarize("green", green), summarize("blue", blue)];
}

// An SVG path (in a kLevels x `height` box, y down) outlining the
// histogram with counts on a log scale, so that a spike of clipped pixels
// does not flatten the rest: bin v spans x in [v, v+1], its height is
// log(1+count)/log(1+max) of the box.
export function histogramPath(histogram: ArrayLike<number>, height: number): string {
  let max = 0;
  for (let v = 0; v < histogram.length; ++v) max = Math.max(max, histogram[v]);
  const scale = max > 0 ? height / Math.log1p(max) : 0;
  const round = (y: number) => Math.round(y * 100) / 100;
  const parts = [`M0 ${height}`];
  for (let v = 0; v < histogram.length; ++v) {
    const y = round(height - Math.log1p(histogram[v]) * scale);
    parts.push(`L${v} ${y}L${v + 1} ${y}`);
  }
  parts.push(`L${histogram.length} ${height}Z`);
  return parts.join("");
}
