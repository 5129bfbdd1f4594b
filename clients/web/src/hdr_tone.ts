// SPDX-License-Identifier: GPL-3.0-or-later
//
// How the HDR viewer shows linear radiance on a screen: multiply by 2^EV,
// clip to [0, 1], encode with the sRGB curve. The WebGL shader does the
// same per pixel (kHdrFragmentShader); the 2D fallback uses these
// functions, and the tests pin the numbers both follow.

// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
export function srgbEncode(linear: number): number {
  if (!(linear > 0)) return 0;
  if (linear >= 1) return 1;
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * Math.pow(linear, 1 / 2.4) - 0.055;
}

// One radiance value at exposure `ev` as an 8-bit sRGB code.
export function toneByte(radiance: number, ev: number): number {
  return Math.round(255 * srgbEncode(radiance * Math.pow(2, ev)));
}

// The EV that puts the 99th percentile of luminance at display white (so
// highlights just clip), from at most ~65k sampled pixels; 0 for an image
// without a positive finite value.
export function autoExposureEv(data: Float32Array, channels: 1 | 3): number {
  const pixels = data.length / channels;
  const step = Math.max(1, Math.floor(pixels / 65536));
  const lum: number[] = [];
  for (let p = 0; p < pixels; p += step) {
    const i = p * channels;
    const l = channels === 3
      ? 0.2126 * data[i] + 0.7152 * data[i + 1] + 0.0722 * data[i + 2]
      : data[i];
    if (Number.isFinite(l) && l > 0) lum.push(l);
  }
  if (lum.length === 0) return 0;
  lum.sort((a, b) => a - b);
  const p99 = lum[Math.min(lum.length - 1, Math.floor(0.99 * lum.length))];
  return Math.round(-Math.log2(p99) * 10) / 10;
}

// The sRGB curve as 4097 8-bit codes over [0, 1]: the CPU path's lookup.
const kCurveSteps = 4096;
const kCurve: Uint8Array = (() => {
  const table = new Uint8Array(kCurveSteps + 1);
  for (let i = 0; i <= kCurveSteps; ++i) table[i] = Math.round(255 * srgbEncode(i / kCurveSteps));
  return table;
})();

export interface Size {
  width: number;
  height: number;
}

// Fills RGBA bytes (ImageData's layout) of `to` from a radiance map of
// `from` (the map's pixel under each output pixel, as the shader does) at
// exposure ev, through the table, so a pixel costs a multiply and a lookup
// per channel.
export function toneInto(data: Float32Array, channels: 1 | 3, from: Size, ev: number,
                         out: Uint8ClampedArray, to: Size = from): void {
  const k = Math.pow(2, ev) * kCurveSteps;
  const code = (v: number) => {
    const t = v * k;
    return t > 0 ? kCurve[t >= kCurveSteps ? kCurveSteps : Math.round(t)] : 0;
  };
  const sx = from.width / to.width;
  const sy = from.height / to.height;
  for (let y = 0; y < to.height; ++y) {
    const row = Math.min(from.height - 1, Math.floor((y + 0.5) * sy)) * from.width;
    for (let x = 0; x < to.width; ++x) {
      const i = (row + Math.min(from.width - 1, Math.floor((x + 0.5) * sx))) * channels;
      const o = 4 * (y * to.width + x);
      if (channels === 3) {
        out[o] = code(data[i]);
        out[o + 1] = code(data[i + 1]);
        out[o + 2] = code(data[i + 2]);
      } else {
        out[o] = out[o + 1] = out[o + 2] = code(data[i]);
      }
      out[o + 3] = 255;
    }
  }
}

// The same curve on the GPU: texelFetch (no filtering, so a float texture
// needs no extension) of the map's pixel under each canvas pixel (the
// canvas may be drawn smaller than the map: `scale` is map size / canvas
// size), rows flipped because the texture holds the image top row first
// while gl_FragCoord counts from the bottom.
export const kHdrVertexShader = `#version 300 es
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}`;

export const kHdrFragmentShader = `#version 300 es
precision highp float;
uniform highp sampler2D radiance;
uniform float gain;  // 2^EV
uniform vec2 scale;
out vec4 color;
vec3 srgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
  ivec2 size = textureSize(radiance, 0);
  // gl_FragCoord is a pixel centre (x + 0.5): the nearest map pixel.
  ivec2 p = min(ivec2(floor(gl_FragCoord.xy * scale)), size - 1);
  vec3 v = texelFetch(radiance, ivec2(p.x, size.y - 1 - p.y), 0).rgb;
  color = vec4(srgb(v * gain), 1.0);
}`;

// The drawing-buffer size for a map shown `shownWidth` CSS pixels wide on a
// screen of `pixelRatio`: the screen's pixels, never more than the map's.
export function drawSize(mapWidth: number, mapHeight: number, shownWidth: number,
                         pixelRatio: number): { width: number; height: number } {
  const width = Math.max(1, Math.min(mapWidth, Math.round(shownWidth * pixelRatio)));
  return { width, height: Math.max(1, Math.round((width * mapHeight) / mapWidth)) };
}
