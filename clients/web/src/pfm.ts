// SPDX-License-Identifier: GPL-3.0-or-later
//
// Portable Float Map (PFM) reader for the radiance maps and disparities
// processing writes: "PF" (RGB) or "Pf" (grey), width and height, then a
// scale whose sign gives the byte order (negative: little-endian), then
// width*height*channels float32 values, rows from the bottom of the image
// up. The declared size is checked against limits and against the bytes
// present before anything is allocated, so a hostile or truncated file
// fails with a message instead of exhausting memory.

export interface Pfm {
  width: number;
  height: number;
  channels: 1 | 3;
  littleEndian: boolean;
  scale: number;  // |scale| as written (1.0 for hdrstereo's files)
  // Values in native order, rows from the TOP of the image down:
  // data[(y * width + x) * channels + c].
  data: Float32Array;
}

// Limits on what the console will open: a 44-megapixel RGB map (a 24 MP
// DSLR's 6000x4000x3 is 72 M values), small enough that a header cannot ask
// for gigabytes.
export const kMaxPfmSide = 16384;
export const kMaxPfmValues = 128 * 1024 * 1024;  // 512 MiB of float32

export class PfmError extends Error {
  constructor(message: string) {
    super(`PFM: ${message}`);
    this.name = "PfmError";
  }
}

function isSpace(b: number): boolean {
  return b === 0x20 || b === 0x09 || b === 0x0a || b === 0x0d;
}

// Reads the three header tokens; returns them and the offset of the data
// (one whitespace byte after the scale, as the format prescribes).
function readHeader(bytes: Uint8Array): { tokens: string[]; dataOffset: number } {
  const tokens: string[] = [];
  let i = 0;
  const limit = Math.min(bytes.length, 256);  // a header is a few dozen bytes
  while (tokens.length < 4) {
    while (i < limit && isSpace(bytes[i])) ++i;
    const start = i;
    while (i < limit && !isSpace(bytes[i])) ++i;
    if (i >= limit) {
      throw new PfmError(limit < 256
        ? "the file ends inside its header (expected PF or Pf, width, height, scale)"
        : "no complete header in the first 256 bytes");
    }
    tokens.push(String.fromCharCode(...bytes.subarray(start, i)));
  }
  return { tokens, dataOffset: i + 1 };
}

function parseSide(token: string, what: string): number {
  if (!/^[0-9]+$/.test(token)) throw new PfmError(`${what} "${token}" is not a positive integer`);
  const n = Number(token);
  if (n < 1 || n > kMaxPfmSide) {
    throw new PfmError(`${what} ${token} is outside 1..${kMaxPfmSide}`);
  }
  return n;
}

export function parsePfm(buffer: ArrayBuffer): Pfm {
  const bytes = new Uint8Array(buffer);
  const { tokens, dataOffset } = readHeader(bytes);
  const [type, w, h, s] = tokens;
  let channels: 1 | 3;
  if (type === "PF") channels = 3;
  else if (type === "Pf") channels = 1;
  else throw new PfmError(`unknown type "${type.slice(0, 8)}" (expected PF or Pf)`);
  const width = parseSide(w, "width");
  const height = parseSide(h, "height");
  const scale = Number(s);
  if (!/^[-+]?[0-9.eE+-]+$/.test(s) || !Number.isFinite(scale) || scale === 0) {
    throw new PfmError(`scale "${s}" is not a non-zero number`);
  }
  const values = width * height * channels;
  if (values > kMaxPfmValues) {
    throw new PfmError(`${width}x${height}x${channels} is more than ${kMaxPfmValues} values`);
  }
  const expected = values * 4;
  const present = bytes.length - dataOffset;
  if (present !== expected) {
    throw new PfmError(`${width}x${height}x${channels} needs ${expected} bytes of data, ` +
                       `the file has ${Math.max(present, 0)}` +
                       (present < expected ? " (truncated)" : ""));
  }
  const littleEndian = scale < 0;
  const view = new DataView(buffer, dataOffset, expected);
  const data = new Float32Array(values);
  const rowValues = width * channels;
  for (let row = 0; row < height; ++row) {
    // File row `row` counts from the bottom; it lands at height-1-row.
    const src = row * rowValues * 4;
    const dst = (height - 1 - row) * rowValues;
    for (let i = 0; i < rowValues; ++i) {
      data[dst + i] = view.getFloat32(src + i * 4, littleEndian);
    }
  }
  return { width, height, channels, littleEndian, scale: Math.abs(scale), data };
}

// The value at (x, y), y from the top; channel 0 unless given.
export function pfmAt(pfm: Pfm, x: number, y: number, channel = 0): number {
  return pfm.data[(y * pfm.width + x) * pfm.channels + channel];
}
