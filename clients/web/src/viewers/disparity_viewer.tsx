// SPDX-License-Identifier: GPL-3.0-or-later
//
// A disparity (or ground-truth) PFM in viridis, pixels without a value in
// grey, a legend in numbers and words, and a read-out of the pixel under
// the pointer or the keyboard cursor: disparity, the ground truth there and
// the error |d − gt|. The read-out element carries data-x, data-y,
// data-disparity, data-truth and data-error (the float32 values exactly,
// "" where there is none) for the browser test. The read-out is not a live
// region (it changes on every pointer move); a keyboard move is announced
// through a hidden one.
import { useEffect, useId, useMemo, useRef, useState } from "preact/hooks";
import { colorize, finiteRange, kInvalidRgb, kViridis, rgbCss, type Range } from "../colormap";
import { pfmAt, type Pfm } from "../pfm";
import { clientToPixel, type Pixel, pixelToBox, stepPixel } from "../pixel_map";
import { usePfm } from "./load_pfm";

type Layer = "disparity" | "truth" | "error";

// Errors are drawn on 0..kErrorSpanPx (beyond it: the top colour), the
// range the bad-pixel thresholds span.
const kErrorSpanPx = 4;

function errorMap(d: Pfm, gt: Pfm): Float32Array {
  const out = new Float32Array(d.width * d.height);
  for (let i = 0; i < out.length; ++i) {
    const a = d.data[i * d.channels];
    const b = gt.data[i * gt.channels];
    out[i] = Number.isFinite(a) && Number.isFinite(b) ? Math.abs(a - b) : NaN;
  }
  return out;
}

function channel0(p: Pfm): Float32Array {
  if (p.channels === 1) return p.data;
  const out = new Float32Array(p.width * p.height);
  for (let i = 0; i < out.length; ++i) out[i] = p.data[i * p.channels];
  return out;
}

function fmt(v: number | undefined, digits = 3): string {
  if (v === undefined) return "–";
  return Number.isFinite(v) ? `${v.toFixed(digits)} px` : `none (${v})`;
}

function Legend({ range, unit, invalid, total, title }:
                { range: Range; unit: string; invalid: number; total: number; title: string }) {
  const stops = 16;
  const id = `legend-${useId()}`;  // unique per viewer: url(#id) finds this one
  return (
    <div class="legend" data-min={String(range.min)} data-max={String(range.max)}>
      <svg width="260" height="22" viewBox="0 0 260 22" preserveAspectRatio="none" aria-hidden="true">
        <defs>
          <linearGradient id={id}>
            {Array.from({ length: stops + 1 }, (_, i) => {
              const k = 3 * Math.min(255, Math.round((i / stops) * 255));
              return <stop key={i} offset={`${(i / stops) * 100}%`}
                           stop-color={rgbCss([kViridis[k], kViridis[k + 1], kViridis[k + 2]])} />;
            })}
          </linearGradient>
        </defs>
        <rect x="0" y="2" width="260" height="18" fill={`url(#${id})`} stroke="#55606e" />
      </svg>
      <div class="legend-scale mono">
        <span>min {range.min.toFixed(2)} {unit}</span>
        <span>max {range.max.toFixed(2)} {unit}</span>
      </div>
      <p class="legend-words">{title}: dark purple = low, through teal and green, to yellow = high</p>
      <p class="legend-invalid">
        <span class="swatch" style={{ background: rgbCss(kInvalidRgb) }} aria-hidden="true" />
        Grey: no value (NaN or infinite) — {invalid} of {total} pixels
        ({total ? ((100 * invalid) / total).toFixed(1) : "0.0"} %)
      </p>
    </div>
  );
}

export interface DisparityViewerProps {
  url: string;
  label: string;
  truthUrl?: string;    // the left view's ground truth, when the session has one
  truthLabel?: string;
  truthNote?: string;   // said instead when there is no truth to compare with
}

export function DisparityViewer({ url, label, truthUrl, truthLabel, truthNote }: DisparityViewerProps) {
  const disparity = usePfm(url);
  const truthLoad = usePfm(truthUrl);
  const d = disparity.pfm;
  const gtCandidate = truthLoad.pfm;
  const gt = gtCandidate && d && gtCandidate.width === d.width && gtCandidate.height === d.height
    ? gtCandidate : undefined;
  const sizeMismatch = gtCandidate && d && !gt;
  const [layer, setLayer] = useState<Layer>("disparity");
  const [cursor, setCursor] = useState<Pixel | null>(null);
  const [announced, setAnnounced] = useState("");
  const layerName = `disparity-layer-${useId()}`;
  const canvasRef = useRef<HTMLCanvasElement>(null);
  const [, setShownWidth] = useState(0);  // re-render the cursor when the canvas resizes

  const shown = useMemo(() => {
    if (!d) return undefined;
    if (layer === "error" && gt) {
      const values = errorMap(d, gt);
      const r = finiteRange(values);
      return { values, range: { ...r, min: 0, max: kErrorSpanPx }, unit: "px", title: "|d − gt|" };
    }
    const values = channel0(layer === "truth" && gt ? gt : d);
    return { values, range: finiteRange(values), unit: "px", title: layer === "truth" ? "ground truth" : "disparity" };
  }, [d, gt, layer]);

  useEffect(() => {
    const canvas = canvasRef.current;
    if (!d || !shown || !canvas) return;
    canvas.width = d.width;
    canvas.height = d.height;
    const ctx = canvas.getContext("2d");
    if (!ctx) return;
    const image = ctx.createImageData(d.width, d.height);
    colorize(shown.values, shown.range.min, shown.range.max, image.data);
    ctx.putImageData(image, 0, 0);
  }, [d, shown]);

  useEffect(() => {
    const canvas = canvasRef.current;
    if (!canvas || typeof ResizeObserver === "undefined") return;
    const observer = new ResizeObserver(() => setShownWidth(canvas.clientWidth));
    observer.observe(canvas);
    return () => observer.disconnect();
  }, []);

  const valuesAt = (p: Pixel | null) => {
    if (!p || !d) return undefined;
    const disparity = pfmAt(d, p.x, p.y);
    const truth = gt ? pfmAt(gt, p.x, p.y) : undefined;
    const error = truth !== undefined && Number.isFinite(disparity) && Number.isFinite(truth)
      ? Math.abs(disparity - truth) : undefined;
    return { disparity, truth, error };
  };
  const at = valuesAt(cursor);
  const error = at?.error;

  const onPointer = (e: PointerEvent) => {
    const canvas = canvasRef.current;
    if (!canvas || !d) return;
    const p = clientToPixel(e.clientX, e.clientY, canvas.getBoundingClientRect(), d.width, d.height);
    if (p && (p.x !== cursor?.x || p.y !== cursor?.y)) setCursor(p);
  };
  const onKey = (e: KeyboardEvent) => {
    if (!d) return;
    const start = cursor ?? { x: Math.floor(d.width / 2), y: Math.floor(d.height / 2) };
    const next = stepPixel(start, e.key, e.shiftKey ? 10 : 1, d.width, d.height);
    if (next) {
      e.preventDefault();
      setCursor(next);
      const v = valuesAt(next)!;
      setAnnounced(`x ${next.x}, y ${next.y}: disparity ${fmt(v.disparity)}` +
                   (gt ? `, ground truth ${fmt(v.truth)}, error ${fmt(v.error)}` : ""));
    }
  };
  const canvas = canvasRef.current;
  const marker = cursor && d && canvas
    ? pixelToBox(cursor, { left: 0, top: 0, width: canvas.clientWidth, height: canvas.clientHeight },
                 d.width, d.height)
    : undefined;

  const problem = disparity.error ?? truthLoad.error;
  return (
    <div class="disparity-viewer">
      {problem && <p class="error" role="alert"><strong>Error:</strong> {problem}</p>}
      {!d && !disparity.error && <p class="muted" role="status">Loading the disparity map…</p>}
      {sizeMismatch && (
        <p class="notice">The ground truth is {gtCandidate!.width}×{gtCandidate!.height}, the
          disparity {d!.width}×{d!.height}: no comparison.</p>
      )}
      {d && (
        <fieldset class="viewer-controls row">
          <legend class="visually-hidden">Map shown</legend>
          {(["disparity", "truth", "error"] as Layer[]).map((l) => (
            <label key={l} class="choice">
              <input type="radio" name={layerName} value={l} checked={layer === l}
                     disabled={l !== "disparity" && !gt} onChange={() => setLayer(l)} />
              {l === "disparity" ? "Disparity" : l === "truth" ? "Ground truth" : `Error |d − gt| (0–${kErrorSpanPx} px)`}
            </label>
          ))}
        </fieldset>
      )}
      <div class="viewer-layout" hidden={!d}>
        <div class="viewer-stage">
          <canvas ref={canvasRef} class="viewer-canvas" tabIndex={0} role="img"
                  aria-label={`${label}, ${d?.width ?? 0} by ${d?.height ?? 0} pixels; arrow keys move the read-out cursor, with Shift by 10 pixels`}
                  aria-describedby="disparity-readout"
                  onPointerMove={onPointer} onPointerDown={onPointer} onKeyDown={onKey} />
          {marker && (
            <div class="cursor-marker" aria-hidden="true"
                 style={{ left: `${marker.left + marker.width / 2}px`, top: `${marker.top + marker.height / 2}px` }} />
          )}
        </div>
        {d && (
          <div class="viewer-side">
            <p class="visually-hidden" aria-live="polite">{announced}</p>
            {/* An <output> is a live region unless told otherwise. */}
            <output id="disparity-readout" class="readout" aria-live="off"
                    data-x={cursor ? String(cursor.x) : ""} data-y={cursor ? String(cursor.y) : ""}
                    data-disparity={at ? String(at.disparity) : ""}
                    data-truth={at?.truth !== undefined ? String(at.truth) : ""}
                    data-error={error !== undefined ? String(error) : ""}>
              {cursor && at ? (
                <dl class="facts mono">
                  <dt>pixel</dt><dd>x {cursor.x}, y {cursor.y}</dd>
                  <dt>disparity</dt><dd>{fmt(at.disparity)}</dd>
                  <dt>ground truth</dt><dd>{gt ? fmt(at.truth) : "–"}</dd>
                  <dt>error |d − gt|</dt><dd>{error !== undefined ? fmt(error) : "–"}</dd>
                </dl>
              ) : "Point at the map, or focus it and use the arrow keys, to read a pixel."}
            </output>
            {shown && (
              <Legend range={shown.range} unit={shown.unit} title={shown.title} total={shown.range.total}
                      invalid={shown.range.total - shown.range.finite} />
            )}
            <p class="help">
              {d.width}×{d.height} {d.channels === 1 ? "one-channel" : "three-channel (first shown)"} float
              PFM; viridis from the minimum to the maximum of its finite values; values in pixels
              to 3 decimals.
              {gt ? ` Ground truth: ${truthLabel ?? "given"}.`
                : ` ${truthNote ? `No comparison: ${truthNote}` : "No ground truth in this session"}.`}
            </p>
          </div>
        )}
      </div>
    </div>
  );
}
