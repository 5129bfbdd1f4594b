// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import {
  artifactView, barScale, browserShowsImage, checkExposure, companionImages, coverageImages,
  formatPercent, formatPx, groundTruthOf, groupArtifacts, hex,
} from "../src/results";

test("the camera's exposure against the one set: within 1/6 stop matches", () => {
  assert.deepEqual(checkExposure(0.004, 0.004), { state: "match", text: "camera reports 1/250 s" });
  // 1/30 set, camera rounds to 1/32 (0.09 stop): still the setting.
  assert.equal(checkExposure(1 / 30, 1 / 32).state, "match");
  assert.deepEqual(checkExposure(1 / 250, 1 / 125), {
    state: "differs", text: "camera reports 1/125 s, set 1/250 s (1.00 stops off)",
  });
  assert.equal(checkExposure(1 / 250, 0).state, "differs");
  assert.deepEqual(checkExposure(1 / 250, undefined),
                   { state: "unreported", text: "the file reports no exposure" });
});

test("digests as lower-case hex", () => {
  assert.equal(hex(new Uint8Array([0, 15, 16, 255]).buffer), "000f10ff");
});

const a = (id: number, kind: string, path: string) => ({ id: BigInt(id), kind, path });
const artifacts = [
  a(1, "report", "report/index.html"),
  a(2, "disparity", "disparity/fused.pfm"),
  a(3, "hdr", "hdr/im0.pfm"),
  a(4, "ground_truth", "ground_truth/structured_light/disp0GT.pfm"),
  a(5, "ground_truth", "ground_truth/structured_light/disp1GT.pfm"),
  a(6, "disparity", "disparity/hdr_lr.png"),
  a(7, "report", "report/error_structured_light_fused.png"),
  a(8, "zeta", "x/y.bin"),
  a(9, "manifest", "pipeline/hdr.json"),
  a(10, "disparity", "disparity/fused_lr.png"),
  a(11, "report", "report/gt_structured_light.png"),
  a(12, "ground_truth", "ground_truth/structured_light/mask0nocc.png"),
  a(13, "export", "disp0GT.pfm"),
];

test("how each artifact opens", () => {
  assert.equal(artifactView(artifacts[1]), "disparity");
  assert.equal(artifactView(artifacts[2]), "hdr");
  assert.equal(artifactView(artifacts[3]), "disparity");
  assert.equal(artifactView(artifacts[12]), "disparity");
  assert.equal(artifactView(artifacts[5]), "image");
  assert.equal(artifactView(artifacts[0]), "download");
  assert.equal(artifactView(artifacts[8]), "download");
  assert.equal(browserShowsImage("a/b.JPG"), true);
  assert.equal(browserShowsImage("a/b.tif"), false);
  assert.equal(browserShowsImage("a/b.cr2"), false);
});

test("artifacts group by step in pipeline order, unknown kinds last", () => {
  const groups = groupArtifacts(artifacts);
  assert.deepEqual(groups.map((g) => g.kind),
                   ["hdr", "ground_truth", "disparity", "export", "report", "manifest", "zeta"]);
  assert.deepEqual(groups[2].artifacts.map((x) => Number(x.id)), [2, 6, 10]);
});

test("the left ground truth, a disparity's companions, the coverage images", () => {
  assert.equal(groundTruthOf(artifacts)?.id, 4n);
  assert.equal(groundTruthOf([artifacts[0]]), undefined);
  assert.deepEqual(companionImages(artifacts[1], artifacts).map((x) => Number(x.id)), [10, 7]);
  assert.deepEqual(companionImages(artifacts[2], artifacts), []);
  assert.deepEqual(coverageImages(artifacts).map((x) => Number(x.id)), [11, 12]);
});

test("metrics at their stated precision", () => {
  assert.equal(formatPx(2.6584999), "2.658");
  assert.equal(formatPx(11.0886), "11.089");
  assert.equal(formatPx(0.0004), "0.000");
  assert.equal(formatPercent(48.36), "48.4 %");
  assert.equal(formatPercent(100), "100.0 %");
  assert.equal(formatPx(NaN), "–");
});

test("bar axes end at a round number above every value", () => {
  assert.deepEqual(barScale([2.6, 31.1, 13.2]), { max: 50, ticks: [0, 10, 20, 30, 40, 50] });
  assert.deepEqual(barScale([48.4, 89.4]), { max: 100, ticks: [0, 20, 40, 60, 80, 100] });
  assert.deepEqual(barScale([1.6, 1.8]), { max: 2, ticks: [0, 0.5, 1, 1.5, 2] });
  assert.deepEqual(barScale([0.7]), { max: 1, ticks: [0, 0.2, 0.4, 0.6, 0.8, 1] });
  assert.deepEqual(barScale([0, NaN]), { max: 1, ticks: [0, 0.5, 1] });
});
