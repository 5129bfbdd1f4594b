// SPDX-License-Identifier: GPL-3.0-or-later
//
// Portable float maps, read here independently of the console's own
// parser (clients/web/src/pfm.ts) so that the test checks it: "PF" (three
// channels) or "Pf" (one), width and height, a scale whose sign gives the
// byte order (negative: little-endian), then float32 rows bottom to top.

export interface PfmImage {
  width: number;
  height: number;
  channels: number;
  data: Float32Array;  // rows top to bottom, channels interleaved
}

export function parsePfm(bytes: Buffer): PfmImage {
  // Three whitespace-separated header lines, each ended by one newline.
  let offset = 0;
  const fields: string[] = [];
  while (fields.length < 4) {
    const end = bytes.indexOf(0x0a, offset);
    if (end < 0) throw new Error("PFM: header ends early");
    fields.push(...bytes.subarray(offset, end).toString("latin1").trim().split(/\s+/)
      .filter((f) => f !== ""));
    offset = end + 1;
  }
  const [magic, w, h, s] = fields;
  if (magic !== "PF" && magic !== "Pf") throw new Error(`PFM: magic ${magic}`);
  const channels = magic === "PF" ? 3 : 1;
  const width = Number(w);
  const height = Number(h);
  const littleEndian = Number(s) < 0;
  const count = width * height * channels;
  if (bytes.length - offset < count * 4) throw new Error("PFM: data ends early");
  const view = new DataView(bytes.buffer, bytes.byteOffset + offset, count * 4);
  const data = new Float32Array(count);
  for (let row = 0; row < height; ++row) {
    const fileRow = height - 1 - row;
    for (let i = 0; i < width * channels; ++i) {
      data[row * width * channels + i] =
        view.getFloat32((fileRow * width * channels + i) * 4, littleEndian);
    }
  }
  return { width, height, channels, data };
}

// The first channel at (x, y), y from the top.
export function pfmValue(image: PfmImage, x: number, y: number): number {
  return image.data[(y * image.width + x) * image.channels];
}
