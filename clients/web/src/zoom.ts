// SPDX-License-Identifier: GPL-3.0-or-later
//
// The 1:1 zoom of live view: which region of the image (in image pixels)
// a second canvas shows at one image pixel per screen pixel, chosen by a
// click on the scaled image and moved by arrow keys, always inside the
// image.

export interface Size {
  width: number;
  height: number;
}

export interface Region extends Size {
  x: number;  // left column
  y: number;  // top row
}

const clamp = (v: number, lo: number, hi: number) => Math.min(Math.max(v, lo), hi);

// The region of `size` (at most the image) centred on image point (cx, cy),
// shifted to lie inside the image.
export function regionAround(cx: number, cy: number, size: Size, image: Size): Region {
  const width = Math.min(size.width, image.width);
  const height = Math.min(size.height, image.height);
  return {
    x: clamp(Math.round(cx - width / 2), 0, image.width - width),
    y: clamp(Math.round(cy - height / 2), 0, image.height - height),
    width,
    height,
  };
}

// `region` moved by (dx, dy) image pixels, kept inside the image.
export function moveRegion(region: Region, dx: number, dy: number, image: Size): Region {
  return regionAround(region.x + region.width / 2 + dx, region.y + region.height / 2 + dy,
                      region, image);
}

// The image pixel under a point (px, py) of the image as displayed at
// `shown` size (CSS pixels from its top-left corner).
export function imagePoint(px: number, py: number, shown: Size, image: Size): { x: number; y: number } {
  return {
    x: clamp(Math.floor((px / shown.width) * image.width), 0, image.width - 1),
    y: clamp(Math.floor((py / shown.height) * image.height), 0, image.height - 1),
  };
}

// Arrow keys move the region by `step` image pixels (Shift: 4x); other keys
// give undefined.
export function arrowStep(key: string, shift: boolean, step = 16): { dx: number; dy: number } | undefined {
  const s = shift ? step * 4 : step;
  switch (key) {
    case "ArrowLeft": return { dx: -s, dy: 0 };
    case "ArrowRight": return { dx: s, dy: 0 };
    case "ArrowUp": return { dx: 0, dy: -s };
    case "ArrowDown": return { dx: 0, dy: s };
    default: return undefined;
  }
}
