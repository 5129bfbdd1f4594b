// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { clientToPixel, pixelToBox, stepPixel } from "../src/pixel_map";

// A 1200x900 map shown at 600x450 with its corner at (100, 50) on the page.
const box = { left: 100, top: 50, width: 600, height: 450 };

test("a pointer position maps to the image pixel under it", () => {
  assert.deepEqual(clientToPixel(100, 50, box, 1200, 900), { x: 0, y: 0 });
  assert.deepEqual(clientToPixel(100.6, 50.4, box, 1200, 900), { x: 1, y: 0 });
  assert.deepEqual(clientToPixel(400, 275, box, 1200, 900), { x: 600, y: 450 });
  assert.deepEqual(clientToPixel(699.9, 499.9, box, 1200, 900), { x: 1199, y: 899 });
  assert.equal(clientToPixel(700, 300, box, 1200, 900), null);
  assert.equal(clientToPixel(99, 300, box, 1200, 900), null);
  assert.equal(clientToPixel(300, 300, { ...box, width: 0 }, 1200, 900), null);
});

test("a pixel maps back to its box on the page, and the centre round-trips", () => {
  assert.deepEqual(pixelToBox({ x: 600, y: 450 }, box, 1200, 900),
                   { left: 300, top: 225, width: 0.5, height: 0.5 });
  for (const p of [{ x: 0, y: 0 }, { x: 17, y: 883 }, { x: 1199, y: 899 }]) {
    const b = pixelToBox(p, box, 1200, 900);
    assert.deepEqual(clientToPixel(box.left + b.left + b.width / 2, box.top + b.top + b.height / 2,
                                   box, 1200, 900), p);
  }
});

test("arrow keys move the cursor, clamped to the image", () => {
  assert.deepEqual(stepPixel({ x: 5, y: 5 }, "ArrowRight", 1, 10, 10), { x: 6, y: 5 });
  assert.deepEqual(stepPixel({ x: 5, y: 5 }, "ArrowUp", 10, 10, 10), { x: 5, y: 0 });
  assert.deepEqual(stepPixel({ x: 5, y: 5 }, "ArrowDown", 10, 10, 10), { x: 5, y: 9 });
  assert.deepEqual(stepPixel({ x: 0, y: 5 }, "ArrowLeft", 1, 10, 10), { x: 0, y: 5 });
  assert.equal(stepPixel({ x: 5, y: 5 }, "Enter", 1, 10, 10), null);
});
