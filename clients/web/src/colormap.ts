// SPDX-License-Identifier: GPL-3.0-or-later
//
// Colour maps for disparities and errors: viridis (matplotlib's 256-entry
// table, perceptually uniform, readable with the common colour-vision
// deficiencies and in grey print), a neutral grey for pixels without a
// value, and the mapping of a value range onto the table.

export type Rgb = [number, number, number];

// viridis, 256 entries of RRGGBB, from matplotlib's _cm_listed.py (CC0).
const kViridisHex =
  "44015444025645045745055946075a46085c460a5d460b5e470d60470e61471063471164471365481467481668481769" +
  "48186a481a6c481b6d481c6e481d6f481f70482071482173482374482475482576482677482878482979472a7a472c7a" +
  "472d7b472e7c472f7d46307e46327e46337f463480453581453781453882443983443a83443b84433d84433e85423f85" +
  "4240864241864142874144874045884046883f47883f48893e49893e4a893e4c8a3d4d8a3d4e8a3c4f8a3c508b3b518b" +
  "3b528b3a538b3a548c39558c39568c38588c38598c375a8c375b8d365c8d365d8d355e8d355f8d34608d34618d33628d" +
  "33638d32648e32658e31668e31678e31688e30698e306a8e2f6b8e2f6c8e2e6d8e2e6e8e2e6f8e2d708e2d718e2c718e" +
  "2c728e2c738e2b748e2b758e2a768e2a778e2a788e29798e297a8e297b8e287c8e287d8e277e8e277f8e27808e26818e" +
  "26828e26828e25838e25848e25858e24868e24878e23888e23898e238a8d228b8d228c8d228d8d218e8d218f8d21908d" +
  "21918c20928c20928c20938c1f948c1f958b1f968b1f978b1f988b1f998a1f9a8a1e9b8a1e9c891e9d891f9e891f9f88" +
  "1fa0881fa1881fa1871fa28720a38620a48621a58521a68522a78522a88423a98324aa8325ab8225ac8226ad8127ad81" +
  "28ae8029af7f2ab07f2cb17e2db27d2eb37c2fb47c31b57b32b67a34b67935b77937b87838b9773aba763bbb753dbc74" +
  "3fbc7340bd7242be7144bf7046c06f48c16e4ac16d4cc26c4ec36b50c46a52c56954c56856c66758c7655ac8645cc863" +
  "5ec96260ca6063cb5f65cb5e67cc5c69cd5b6ccd5a6ece5870cf5773d05675d05477d1537ad1517cd2507fd34e81d34d" +
  "84d44b86d54989d5488bd6468ed64590d74393d74195d84098d83e9bd93c9dd93ba0da39a2da37a5db36a8db34aadc32" +
  "addc30b0dd2fb2dd2db5de2bb8de29bade28bddf26c0df25c2df23c5e021c8e020cae11fcde11dd0e11cd2e21bd5e21a" +
  "d8e219dae319dde318dfe318e2e418e5e419e7e419eae51aece51befe51cf1e51df4e61ef6e620f8e621fbe723fde725";

function decode(hex: string): Uint8Array {
  const out = new Uint8Array(hex.length / 2);
  for (let i = 0; i < out.length; ++i) out[i] = parseInt(hex.slice(2 * i, 2 * i + 2), 16);
  return out;
}

// 256 RGB triples, flat.
export const kViridis: Uint8Array = decode(kViridisHex);

// Pixels with no valid value (NaN, infinite): a mid grey, which viridis
// never produces (its colours are all saturated), named in the legend.
export const kInvalidRgb: Rgb = [128, 128, 128];

export function viridis(t: number): Rgb {
  const i = colormapIndex(t);
  return [kViridis[3 * i], kViridis[3 * i + 1], kViridis[3 * i + 2]];
}

// The table index of t in [0, 1], clamped; NaN maps to 0 (callers paint
// non-finite values with kInvalidRgb before asking).
export function colormapIndex(t: number): number {
  if (!(t > 0)) return 0;
  if (t >= 1) return 255;
  return Math.min(255, Math.floor(t * 256));
}

// Where `value` lies in [min, max], as 0..1 (clamped); a degenerate range
// maps everything to 0.
export function normalize(value: number, min: number, max: number): number {
  if (!(max > min)) return 0;
  return Math.min(1, Math.max(0, (value - min) / (max - min)));
}

export interface Range {
  min: number;
  max: number;
  finite: number;  // how many values were finite
  total: number;
}

// The range of the finite values of one channel of a float image.
export function finiteRange(data: Float32Array, channels = 1, channel = 0): Range {
  let min = Infinity;
  let max = -Infinity;
  let finite = 0;
  for (let i = channel; i < data.length; i += channels) {
    const v = data[i];
    if (!Number.isFinite(v)) continue;
    ++finite;
    if (v < min) min = v;
    if (v > max) max = v;
  }
  return { min: finite ? min : 0, max: finite ? max : 0, finite, total: data.length / channels };
}

// Paints a one-channel float image into RGBA bytes (ImageData's layout).
export function colorize(data: Float32Array, min: number, max: number,
                         out: Uint8ClampedArray): void {
  for (let i = 0; i < data.length; ++i) {
    const v = data[i];
    const o = 4 * i;
    if (!Number.isFinite(v)) {
      out[o] = kInvalidRgb[0];
      out[o + 1] = kInvalidRgb[1];
      out[o + 2] = kInvalidRgb[2];
    } else {
      const k = 3 * colormapIndex(normalize(v, min, max));
      out[o] = kViridis[k];
      out[o + 1] = kViridis[k + 1];
      out[o + 2] = kViridis[k + 2];
    }
    out[o + 3] = 255;
  }
}

// CIE L* (0..100) of an sRGB colour: the tests check that the map's
// lightness rises monotonically, which is what makes it readable in grey.
export function lightness([r, g, b]: Rgb): number {
  const lin = (c: number) => {
    const s = c / 255;
    return s <= 0.04045 ? s / 12.92 : Math.pow((s + 0.055) / 1.055, 2.4);
  };
  const y = 0.2126 * lin(r) + 0.7152 * lin(g) + 0.0722 * lin(b);
  return y > 216 / 24389 ? 116 * Math.cbrt(y) - 16 : (24389 / 27) * y;
}

export function rgbCss([r, g, b]: Rgb): string {
  return `rgb(${r}, ${g}, ${b})`;
}
