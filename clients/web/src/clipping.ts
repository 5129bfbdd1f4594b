// SPDX-License-Identifier: GPL-3.0-or-later
//
// Which pixels of a decoded frame are clipped, and the overlay that marks
// them. The thresholds are the daemon's (processing/exposure/
// frame_statistics.cc: ChannelStatistics.clipped_low counts a channel's
// pixels at level 0, clipped_high those at 255): a pixel is marked clipped
// high when any of its channels is at 255 and clipped low when any is at 0.
// The overlay uses a pattern as well as a colour, so that the two marks
// differ without colour vision: clipped high is magenta diagonal hatching
// (the image shows between the stripes), clipped low solid cyan.

export const kClipLowLevel = 0;
export const kClipHighLevel = 255;

// Bits of a mask entry.
export const kClippedHigh = 1;
export const kClippedLow = 2;

// One entry per pixel of RGBA data: kClippedHigh | kClippedLow bits.
export function clipMask(rgba: ArrayLike<number>): Uint8Array {
  const mask = new Uint8Array(Math.floor(rgba.length / 4));
  for (let p = 0, i = 0; p < mask.length; ++p, i += 4) {
    const r = rgba[i], g = rgba[i + 1], b = rgba[i + 2];
    let m = 0;
    if (r === kClipHighLevel || g === kClipHighLevel || b === kClipHighLevel) m |= kClippedHigh;
    if (r === kClipLowLevel || g === kClipLowLevel || b === kClipLowLevel) m |= kClippedLow;
    mask[p] = m;
  }
  return mask;
}

export interface ClipCounts {
  high: number;  // pixels with a channel at 255
  low: number;   // pixels with a channel at 0
}

export function countClipped(mask: Uint8Array): ClipCounts {
  let high = 0;
  let low = 0;
  for (const m of mask) {
    if (m & kClippedHigh) ++high;
    if (m & kClippedLow) ++low;
  }
  return { high, low };
}

export const kHighColour = [255, 0, 255] as const;  // magenta
export const kLowColour = [0, 255, 255] as const;   // cyan
// Hatching: a pixel (x, y) is on a stripe when (x + y) mod kHatchPeriod is
// below kHatchWidth.
export const kHatchPeriod = 6;
export const kHatchWidth = 3;

// The overlay as RGBA (transparent where nothing is clipped) for a mask of
// `width` pixels per row: clipped-high pixels on a stripe are opaque
// magenta, clipped-low pixels (not covered by a stripe) opaque cyan.
export function paintOverlay(mask: Uint8Array, width: number,
                             out: Uint8ClampedArray = new Uint8ClampedArray(mask.length * 4)): Uint8ClampedArray {
  for (let p = 0; p < mask.length; ++p) {
    const m = mask[p];
    const i = p * 4;
    const x = p % width;
    const y = (p - x) / width;
    let colour: readonly number[] | undefined;
    if ((m & kClippedHigh) && (x + y) % kHatchPeriod < kHatchWidth) colour = kHighColour;
    else if (m & kClippedLow) colour = kLowColour;
    if (colour) {
      out[i] = colour[0];
      out[i + 1] = colour[1];
      out[i + 2] = colour[2];
      out[i + 3] = 255;
    } else {
      out[i + 3] = 0;
    }
  }
  return out;
}
