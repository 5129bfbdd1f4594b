// SPDX-License-Identifier: GPL-3.0-or-later
//
// Between a canvas shown scaled on the page and the image pixels it holds:
// a pointer position to the pixel under it, and a pixel to the box it
// covers on the page (for drawing the read-out cursor).

export interface Box {
  left: number;
  top: number;
  width: number;
  height: number;
}

export interface Pixel {
  x: number;
  y: number;
}

// The pixel under (clientX, clientY) of an image of imageWidth x
// imageHeight drawn into `box`; null outside it.
export function clientToPixel(clientX: number, clientY: number, box: Box,
                              imageWidth: number, imageHeight: number): Pixel | null {
  if (box.width <= 0 || box.height <= 0) return null;
  const u = (clientX - box.left) / box.width;
  const v = (clientY - box.top) / box.height;
  if (u < 0 || v < 0 || u >= 1 || v >= 1) return null;
  return {
    x: Math.min(imageWidth - 1, Math.floor(u * imageWidth)),
    y: Math.min(imageHeight - 1, Math.floor(v * imageHeight)),
  };
}

// The box of pixel p on the page, relative to the image's top-left corner.
export function pixelToBox(p: Pixel, box: Box, imageWidth: number, imageHeight: number): Box {
  const sx = box.width / imageWidth;
  const sy = box.height / imageHeight;
  return { left: p.x * sx, top: p.y * sy, width: sx, height: sy };
}

// The pixel an arrow key moves to (step pixels; clamped to the image).
export function stepPixel(p: Pixel, key: string, step: number,
                          imageWidth: number, imageHeight: number): Pixel | null {
  const d: Record<string, [number, number]> = {
    ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1],
  };
  const m = d[key];
  if (!m) return null;
  return {
    x: Math.min(imageWidth - 1, Math.max(0, p.x + m[0] * step)),
    y: Math.min(imageHeight - 1, Math.max(0, p.y + m[1] * step)),
  };
}
