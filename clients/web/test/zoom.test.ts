// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { arrowStep, imagePoint, moveRegion, regionAround } from "../src/zoom";

const image = { width: 640, height: 480 };
const size = { width: 100, height: 80 };

test("the zoom region is centred on the point, inside the image", () => {
  assert.deepEqual(regionAround(320, 240, size, image), { x: 270, y: 200, width: 100, height: 80 });
  assert.deepEqual(regionAround(50, 50, size, image), { x: 0, y: 10, width: 100, height: 80 });
  assert.deepEqual(regionAround(630, 470, size, image), { x: 540, y: 400, width: 100, height: 80 });
  assert.deepEqual(regionAround(10, 10, { width: 800, height: 600 }, image),
                   { x: 0, y: 0, width: 640, height: 480 });
});

test("moving the region keeps it inside the image", () => {
  const r = { x: 0, y: 10, width: 100, height: 80 };
  assert.deepEqual(moveRegion(r, 16, 0, image), { x: 16, y: 10, width: 100, height: 80 });
  assert.deepEqual(moveRegion(r, -100, 0, image), r);
  assert.deepEqual(moveRegion(r, 0, 1000, image), { x: 0, y: 400, width: 100, height: 80 });
});

test("a point on the scaled image maps to the image pixel under it", () => {
  const shown = { width: 320, height: 240 };
  assert.deepEqual(imagePoint(160, 120, shown, image), { x: 320, y: 240 });
  assert.deepEqual(imagePoint(0.4, 0.4, shown, image), { x: 0, y: 0 });
  assert.deepEqual(imagePoint(320, 240, shown, image), { x: 639, y: 479 });
});

test("arrow keys step by 16 image pixels, 64 with Shift", () => {
  assert.deepEqual(arrowStep("ArrowLeft", false), { dx: -16, dy: 0 });
  assert.deepEqual(arrowStep("ArrowDown", true), { dx: 0, dy: 64 });
  assert.equal(arrowStep("a", false), undefined);
});
