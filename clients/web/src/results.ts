// SPDX-License-Identifier: GPL-3.0-or-later
//
// What the sessions page says about a session's files, kept free of the
// page so it can be tested: each frame's agreement with what the camera
// reported, how each artifact can be viewed, how artifacts group by the
// step that made them, and the metrics' stated precision.

import { formatExposure } from "./exposure";

// --- Frames -------------------------------------------------------------

export type ExposureCheck =
  | { state: "match"; text: string }
  | { state: "differs"; text: string }
  | { state: "unreported"; text: string };

// Cameras round shutter times to third stops; within a sixth of a stop of
// what was set counts as the setting the camera used.
export const kExposureToleranceStops = 1 / 6;

// The exposure the camera wrote into the file against the one set.
export function checkExposure(setS: number, cameraS: number | undefined): ExposureCheck {
  if (cameraS === undefined) {
    return { state: "unreported", text: "the file reports no exposure" };
  }
  const stops = Math.abs(Math.log2(cameraS / setS));
  if (Number.isFinite(stops) && stops <= kExposureToleranceStops) {
    return { state: "match", text: `camera reports ${formatExposure(cameraS)}` };
  }
  const off = Number.isFinite(stops) ? ` (${stops.toFixed(2)} stops off)` : "";
  return {
    state: "differs",
    text: `camera reports ${formatExposure(cameraS)}, set ${formatExposure(setS)}${off}`,
  };
}

// Lower-case hex of a digest, to compare with Frame.sha256.
export function hex(bytes: ArrayBuffer): string {
  return Array.from(new Uint8Array(bytes), (b) => b.toString(16).padStart(2, "0")).join("");
}

// Formats a browser can show in <img> (the edge's Content-Type follows the
// extension: PNG and JPEG; a TIFF or camera RAW it cannot).
export function browserShowsImage(path: string): boolean {
  return /\.(png|jpe?g)$/i.test(path);
}

export function extensionOf(path: string): string {
  const m = /\.([A-Za-z0-9]+)$/.exec(path);
  return m ? m[1].toUpperCase() : "file";
}

// --- Artifacts ----------------------------------------------------------

export interface ArtifactLike {
  id: bigint;
  kind: string;
  path: string;
}

// How the console opens an artifact in place: the radiance-map viewer, the
// disparity viewer (disparities and ground truths), an image, or only a
// download.
export type ArtifactView = "hdr" | "disparity" | "image" | "download";

export function artifactView(a: ArtifactLike): ArtifactView {
  const pfm = /\.pfm$/i.test(a.path);
  if (pfm && a.kind === "hdr") return "hdr";
  if (pfm && /disp/i.test(a.path)) return "disparity";
  if (pfm) return "hdr";
  if (browserShowsImage(a.path)) return "image";
  return "download";
}

// The pipeline's steps in the order they run (processing/pipeline), so the
// groups read as the processing went; unknown kinds follow, by name.
const kStepOrder = [
  "decoded", "exposure", "rectification", "response", "hdr", "tonemapped",
  "ground_truth", "disparity", "metrics", "export", "report", "manifest",
];

export interface ArtifactGroup<T extends ArtifactLike> {
  kind: string;
  artifacts: T[];
}

export function groupArtifacts<T extends ArtifactLike>(artifacts: T[]): ArtifactGroup<T>[] {
  const byKind = new Map<string, T[]>();
  for (const a of artifacts) {
    const list = byKind.get(a.kind) ?? [];
    list.push(a);
    byKind.set(a.kind, list);
  }
  const rank = (k: string) => {
    const i = kStepOrder.indexOf(k);
    return i < 0 ? kStepOrder.length : i;
  };
  return [...byKind.keys()]
    .sort((a, b) => rank(a) - rank(b) || a.localeCompare(b))
    .map((kind) => ({ kind, artifacts: byKind.get(kind)! }));
}

// The left view's ground-truth disparity (the one disparities are scored
// against): the structured-light step's disp0GT.pfm.
export function groundTruthOf<T extends ArtifactLike>(artifacts: T[]): T | undefined {
  return artifacts.find((a) => a.kind === "ground_truth" && /disp0GT\.pfm$/i.test(a.path));
}

// Images that belong beside a disparity in the viewer: its left-right
// check and the report's error maps of the same method, by file name.
export function companionImages<T extends ArtifactLike>(disparity: T, artifacts: T[]): T[] {
  const m = /^disparity\/(.+)\.pfm$/i.exec(disparity.path);
  if (!m) return [];
  const method = m[1];
  const wanted = [
    `disparity/${method}_lr.png`,
    `report/error_structured_light_${method}.png`,
    `report/error_simulation_${method}.png`,
  ];
  return wanted.flatMap((p) => artifacts.filter((a) => a.path === p));
}

// The structured-light ground truth's coverage images, as the report made
// them (valid pixels coloured; the invalid mask; the non-occluded mask).
export function coverageImages<T extends ArtifactLike>(artifacts: T[]): T[] {
  const wanted = [
    "report/gt_structured_light.png",
    "report/gt_structured_light_invalid.png",
    "ground_truth/structured_light/mask0nocc.png",
    "report/gt_simulation.png",
    "report/gt_simulation_invalid.png",
  ];
  return wanted.flatMap((p) => artifacts.filter((a) => a.path === p));
}

// --- Metrics ------------------------------------------------------------

// Stated precision: pixels to 3 decimals, percentages to 1.
export function formatPx(v: number): string {
  return Number.isFinite(v) ? v.toFixed(3) : "–";
}

export function formatPercent(v: number): string {
  return Number.isFinite(v) ? `${v.toFixed(1)} %` : "–";
}

export interface BarScale {
  max: number;   // the axis' end (a round number ≥ every value)
  ticks: number[];
}

// A readable axis for bars of these (non-negative) values: ends at 1, 2 or
// 5 times a power of ten, with ticks at round steps (5 or 6 of them).
export function barScale(values: number[]): BarScale {
  const top = Math.max(0, ...values.filter(Number.isFinite));
  if (top === 0) return { max: 1, ticks: [0, 0.5, 1] };
  const p = Math.pow(10, Math.floor(Math.log10(top)));
  const m = [1, 2, 5, 10].find((k) => k * p >= top)!;
  const max = m * p;
  const step = m === 1 || m === 10 ? max / 5 : m === 2 ? max / 4 : max / 5;
  const ticks: number[] = [];
  for (let t = 0; t <= max + step / 2; t += step) ticks.push(Number(t.toPrecision(6)));
  return { max, ticks };
}
