// SPDX-License-Identifier: GPL-3.0-or-later
//
// Live view: the camera's preview stream drawn as it comes, per-channel
// histograms with the 1st/50th/99th percentiles, an overlay of clipped
// pixels, a 1:1 zoom for focusing, the exposure settings, and the
// calibration guide while a calibration capture waits for the next pose.
// When a capture takes the rig the view says so and resumes by itself
// once the capture no longer holds it.
//
// For the browser tests (and anyone inspecting the page), without a
// test-only path: the image canvas carries data-sequence (the sequence
// number of the frame shown last), data-frames-received and
// data-frames-shown; the histogram element carries data-histogram, JSON
// {"sequence": N, "channels": [{"channel", "histogram": [256 counts],
// "p1", "p50", "p99", "mean", "clippedLow", "clippedHigh"}]} computed in
// this browser from the decoded pixels of that frame (src/histogram.ts),
// and data-server-histogram, the same shape from the daemon's
// frame_statistics sent with the frame.
import type { JSX } from "preact";
import { useCallback, useEffect, useRef, useState } from "preact/hooks";
import { Code } from "@connectrpc/connect";
import { api, errorCode, errorMessage } from "../api";
import { ImageFormat } from "../../gen/hdrstereo/v1/common_pb";
import type { CalibrationGuide, CameraSettings, ChannelStatistics, PreviewFrame } from "../../gen/hdrstereo/v1/hardware_pb";
import { CameraSettings_CaptureTarget } from "../../gen/hdrstereo/v1/hardware_pb";
import { type Job, JobState } from "../../gen/hdrstereo/v1/jobs_pb";
import { type ClipCounts, clipMask, countClipped, paintOverlay } from "../clipping";
import { formatExposure, parseExposure } from "../exposure";
import { type ChannelHistogram, histogramPath, kLevels, rgbaStatistics } from "../histogram";
import { atLeast, Role, useMe } from "../identity";
import { captureJobIn, retryDelayMs } from "../preview_retry";
import { RateMeter } from "../rate";
import { href } from "../router";
import { Badge, ErrorBox, Section, sleep } from "../ui";
import { arrowStep, imagePoint, moveRegion, type Region, regionAround } from "../zoom";

// The zoom shows this many image pixels (fewer when the image is smaller).
const kZoomSize = { width: 288, height: 216 };
const kPausedPollMs = 2000;

// What the page knows of the frame it drew last.
interface Shown {
  sequence: bigint;
  width: number;
  height: number;
  exposureS: number;
  fpsCap: number;
  browser: ChannelHistogram[];
  server: ChannelHistogram[];
  clipped: ClipCounts;
  calibration?: CalibrationGuide;
}

type StreamState =
  | { kind: "connecting" }
  | { kind: "live" }
  | { kind: "paused"; jobId: bigint; reason: string; job?: Job }
  | { kind: "retrying"; error?: string; ended?: string; retryAt: number }
  | { kind: "refused"; error: string };  // not retried: the role will not change

function fromServer(c: ChannelStatistics): ChannelHistogram {
  return {
    channel: c.channel, histogram: c.histogram.map(Number), clippedLow: c.clippedLow,
    clippedHigh: c.clippedHigh, mean: c.mean, p1: c.p1, p50: c.p50, p99: c.p99,
  };
}

// Draws frames into the page's canvas as fast as the browser decodes them:
// a frame that arrives while the last one is still being decoded replaces
// any frame waiting behind it, so a slow browser shows fewer frames, never
// old ones. Keeps the decoded pixels to redraw the overlay and the zoom
// without a new frame.
class FrameView {
  received = 0;
  shown = 0;
  skipped = 0;  // frames that could not be decoded or drawn
  readonly delivered = new RateMeter();
  readonly drawn = new RateMeter();
  canvas: HTMLCanvasElement | null = null;
  zoomCanvas: HTMLCanvasElement | null = null;
  overlay = false;
  zoom?: Region;
  private pending?: PreviewFrame;
  private busy = false;
  private pixels?: ImageData;
  private mask?: Uint8Array;
  private overlayData?: ImageData;
  private readonly overlayCanvas = document.createElement("canvas");

  constructor(private readonly onShown: (shown: Shown) => void) {}

  receive(frame: PreviewFrame): void {
    ++this.received;
    this.delivered.record(performance.now());
    this.pending = frame;
    if (!this.busy) void this.drain();
  }

  // One frame at a time; a frame that cannot be decoded or drawn is
  // skipped and counted, and the one waiting behind it is still drawn.
  private async drain(): Promise<void> {
    this.busy = true;
    try {
      while (this.pending) {
        const frame = this.pending;
        this.pending = undefined;
        try {
          // The JPEG's levels as they are, like the daemon's decoder: no
          // colour management.
          const bitmap = await createImageBitmap(
            new Blob([frame.jpeg as Uint8Array<ArrayBuffer>], { type: "image/jpeg" }),
            { colorSpaceConversion: "none" });
          try {
            this.draw(frame, bitmap);
          } finally {
            bitmap.close();
          }
        } catch (e) {
          ++this.skipped;
          console.warn(`live view: frame ${frame.sequence} could not be drawn:`, e);
        }
      }
    } finally {
      this.busy = false;
    }
  }

  private draw(frame: PreviewFrame, bitmap: ImageBitmap): void {
    const canvas = this.canvas;
    const ctx = canvas?.getContext("2d", { willReadFrequently: true });
    if (!canvas || !ctx) return;
    if (canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
      canvas.width = bitmap.width;
      canvas.height = bitmap.height;
    }
    ctx.drawImage(bitmap, 0, 0);
    this.pixels = ctx.getImageData(0, 0, bitmap.width, bitmap.height);
    this.mask = clipMask(this.pixels.data);
    this.compose(false);
    ++this.shown;
    this.drawn.record(performance.now());
    this.onShown({
      sequence: frame.sequence, width: bitmap.width, height: bitmap.height,
      exposureS: frame.exposureS, fpsCap: frame.fpsCap,
      browser: rgbaStatistics(this.pixels.data), server: frame.channels.map(fromServer),
      clipped: countClipped(this.mask), calibration: frame.calibration,
    });
  }

  // Draws the overlay and the zoom over the last frame; `base` redraws the
  // frame's pixels first (after the overlay was turned off, say).
  compose(base = true): void {
    const canvas = this.canvas;
    const ctx = canvas?.getContext("2d", { willReadFrequently: true });
    if (!canvas || !ctx || !this.pixels || !this.mask) return;
    if (base) ctx.putImageData(this.pixels, 0, 0);
    if (this.overlay) {
      const { width, height } = this.pixels;
      if (this.overlayData?.width !== width || this.overlayData.height !== height) {
        this.overlayData = new ImageData(width, height);
        this.overlayCanvas.width = width;
        this.overlayCanvas.height = height;
      }
      paintOverlay(this.mask, width, this.overlayData.data);
      this.overlayCanvas.getContext("2d")?.putImageData(this.overlayData, 0, 0);
      ctx.drawImage(this.overlayCanvas, 0, 0);
    }
    const zoom = this.zoom;
    const zctx = this.zoomCanvas?.getContext("2d");
    if (zoom && zctx && this.zoomCanvas) {
      if (this.zoomCanvas.width !== zoom.width || this.zoomCanvas.height !== zoom.height) {
        this.zoomCanvas.width = zoom.width;
        this.zoomCanvas.height = zoom.height;
      }
      zctx.drawImage(canvas, zoom.x, zoom.y, zoom.width, zoom.height, 0, 0, zoom.width, zoom.height);
    }
  }
}

const percent = (f: number) => `${(f * 100).toFixed(f > 0 && f < 0.001 ? 3 : 2)} %`;

export function LivePage() {
  const me = useMe();
  const operator = atLeast(me, Role.OPERATOR);
  const [maxFps, setMaxFps] = useState(10);
  const [attempt, setAttempt] = useState(0);  // "Retry now" restarts the stream
  const [stream, setStream] = useState<StreamState>({ kind: "connecting" });
  const [shown, setShown] = useState<Shown | undefined>(undefined);
  const [rates, setRates] = useState({ shown: 0, delivered: 0, received: 0, drawn: 0, skipped: 0 });
  const [overlay, setOverlay] = useState(false);
  const [zoom, setZoom] = useState<Region | undefined>(undefined);
  const [source, setSource] = useState<"server" | "browser">("server");
  const [now, setNow] = useState(Date.now());
  const view = useRef<FrameView | null>(null);
  if (!view.current) view.current = new FrameView(setShown);
  const frameView = view.current;

  // The stream: frames while it runs; paused while a capture holds the rig
  // (the job is polled, and the stream tried again once it is neither
  // running nor paused);
  // after an error or another end, tried again with back-off.
  useEffect(() => {
    if (!operator) return undefined;
    const stop = new AbortController();
    const { signal } = stop;
    const waitForCapture = async (jobId: bigint, reason: string) => {
      setStream({ kind: "paused", jobId, reason });
      while (!signal.aborted) {
        await sleep(kPausedPollMs, signal);
        if (signal.aborted) return;
        try {
          const job = await api.jobs.get({ jobId }, { signal });
          setStream({ kind: "paused", jobId, reason, job });
          // A paused capture still holds the rig; a waiting one (a
          // calibration pose) lets live view run.
          if (job.state !== JobState.RUNNING && job.state !== JobState.PAUSED) return;
        } catch {
          return;  // the stream itself will say what is wrong
        }
      }
    };
    (async () => {
      let failures = 0;
      while (!signal.aborted) {
        setStream((s) => (s.kind === "paused" ? s : { kind: "connecting" }));
        let ended: { reason: string; captureJobId: bigint } | undefined;
        let error: unknown;
        try {
          for await (const m of api.hardware.streamPreview({ maxFps, maxFrames: 0 }, { signal })) {
            if (m.message.case === "frame") {
              failures = 0;
              setStream((s) => (s.kind === "live" ? s : { kind: "live" }));
              frameView.receive(m.message.value);
            } else if (m.message.case === "ended") {
              ended = m.message.value;
            }
          }
        } catch (e) {
          error = e;
        }
        if (signal.aborted) return;
        if (error !== undefined && errorCode(error) === Code.PermissionDenied) {
          setStream({ kind: "refused", error: errorMessage(error) });
          return;
        }
        const refusedFor = error !== undefined && errorCode(error) === Code.FailedPrecondition
          ? captureJobIn(errorMessage(error)) : undefined;
        if (ended && ended.captureJobId !== 0n) {
          await waitForCapture(ended.captureJobId, ended.reason);
          continue;
        }
        if (refusedFor !== undefined) {
          await waitForCapture(refusedFor, errorMessage(error));
          continue;
        }
        ++failures;
        const delay = retryDelayMs(failures);
        setStream({
          kind: "retrying", retryAt: Date.now() + delay,
          error: error !== undefined ? errorMessage(error) : undefined,
          ended: error === undefined ? (ended?.reason ?? "the stream closed") : undefined,
        });
        await sleep(delay, signal);
      }
    })();
    return () => stop.abort();
  }, [maxFps, attempt, frameView, operator]);

  // The rates and a clock for "retrying in N s", twice a second.
  useEffect(() => {
    const timer = setInterval(() => {
      const t = performance.now();
      setRates({
        shown: frameView.drawn.rate(t), delivered: frameView.delivered.rate(t),
        received: frameView.received, drawn: frameView.shown, skipped: frameView.skipped,
      });
      setNow(Date.now());
    }, 500);
    return () => clearInterval(timer);
  }, [frameView]);

  useEffect(() => {
    frameView.overlay = overlay;
    frameView.zoom = zoom;
    frameView.compose();
  }, [overlay, zoom, frameView]);

  const canvasRef = useCallback((c: HTMLCanvasElement | null) => { frameView.canvas = c; }, [frameView]);
  const zoomRef = useCallback((c: HTMLCanvasElement | null) => {
    frameView.zoomCanvas = c;
    if (c) frameView.compose(false);
  }, [frameView]);

  const image = shown ? { width: shown.width, height: shown.height } : undefined;
  const zoomAt = (x: number, y: number) => { if (image) setZoom(regionAround(x, y, kZoomSize, image)); };
  const onImageClick = (e: JSX.TargetedMouseEvent<HTMLDivElement>) => {
    const canvas = frameView.canvas;
    if (!canvas || !image) return;
    const rect = canvas.getBoundingClientRect();
    const p = imagePoint(e.clientX - rect.left, e.clientY - rect.top,
                         { width: rect.width, height: rect.height }, image);
    zoomAt(p.x, p.y);
  };
  const onImageKey = (e: JSX.TargetedKeyboardEvent<HTMLDivElement>) => {
    if (!image) return;
    if (e.key === "Escape" && zoom) {
      setZoom(undefined);
    } else if (e.key === "Enter" || e.key === " ") {
      if (!zoom) zoomAt(image.width / 2, image.height / 2);
    } else {
      const step = arrowStep(e.key, e.shiftKey);
      if (!step) return;
      setZoom(zoom ? moveRegion(zoom, step.dx, step.dy, image)
                   : regionAround(image.width / 2, image.height / 2, kZoomSize, image));
    }
    e.preventDefault();
  };

  const paused = stream.kind === "paused" ? stream : undefined;
  const guide = stream.kind === "live" ? shown?.calibration : undefined;
  const dpr = typeof window !== "undefined" ? window.devicePixelRatio || 1 : 1;

  // The daemon streams live view to operators only (it uses the camera).
  if (!operator) {
    return (
      <div class="live">
        <h1>Live view</h1>
        <p class="notice">Live view needs the operator role (it takes the camera's frames); you are
          signed in as a viewer. The <a href={href("rig")}>Rig</a> page shows the camera's state.</p>
      </div>
    );
  }

  return (
    <div class="live">
      <h1>Live view</h1>
      <StreamLine stream={stream} now={now} onRetry={() => setAttempt((a) => a + 1)} />
      <div class="live-layout">
        <div class="live-main">
          <div class={`live-image${paused ? " is-paused" : ""}`} tabIndex={0} role="application"
               aria-label="Live image" aria-describedby="live-image-help"
               onClick={onImageClick} onKeyDown={onImageKey}>
            <canvas ref={canvasRef} width={640} height={480}
                    data-sequence={shown ? String(shown.sequence) : undefined}
                    data-frames-received={rates.received} data-frames-shown={rates.drawn} />
            {zoom && image && (
              <div class="zoom-box" aria-hidden="true" style={{
                left: `${(zoom.x / image.width) * 100}%`, top: `${(zoom.y / image.height) * 100}%`,
                width: `${(zoom.width / image.width) * 100}%`, height: `${(zoom.height / image.height) * 100}%`,
              }} />
            )}
            {guide && <GuideBadge guide={guide} />}
            {paused && (
              <div class="live-banner" role="status">
                <strong>Paused: capture job {String(paused.jobId)} is running.</strong>{" "}
                Live view resumes by itself when it no longer holds the rig.
              </div>
            )}
            {!shown && !paused && <p class="live-empty">No frame yet.</p>}
          </div>
          <p id="live-image-help" class="help">
            Click the image, or focus it and press Enter, for a 1:1 zoom there; arrow keys move the
            zoom (Shift: faster), Esc closes it.
          </p>
          <p class="live-rate" data-testid="live-rate">
            shown <strong>{rates.shown.toFixed(1)} fps</strong> of {rates.delivered.toFixed(1)} delivered
            {shown && <> (cap {shown.fpsCap} fps)</>} · {rates.drawn} of {rates.received} frames drawn
            {rates.skipped > 0 && <> ({rates.skipped} could not be decoded, skipped)</>}
            {shown && <> · frame #{String(shown.sequence)}, {shown.width}×{shown.height},
              exposure {formatExposure(shown.exposureS)}</>}
          </p>
          <div class="row live-controls">
            <label class="check">
              <input type="checkbox" checked={overlay} onChange={(e) => setOverlay(e.currentTarget.checked)} />
              Mark clipped pixels
            </label>
            <label class="check">
              <input type="checkbox" checked={zoom !== undefined} disabled={!image}
                     onChange={(e) => (e.currentTarget.checked && image
                       ? zoomAt(image.width / 2, image.height / 2) : setZoom(undefined))} />
              1:1 zoom
            </label>
            <label>
              Rate{" "}
              <select value={maxFps} onChange={(e) => setMaxFps(Number(e.currentTarget.value))}>
                {[1, 2, 5, 10].map((f) => <option key={f} value={f}>{f} fps{f === 10 ? " (most)" : ""}</option>)}
              </select>
            </label>
          </div>
          {overlay && (
            <p class="clip-legend">
              <span><span class="swatch swatch-high" aria-hidden="true" /> magenta hatching = clipped
                high (a channel at 255{shown ? `: ${shown.clipped.high} px` : ""})</span>
              <span><span class="swatch swatch-low" aria-hidden="true" /> solid cyan = clipped low
                (a channel at 0{shown ? `: ${shown.clipped.low} px` : ""})</span>
            </p>
          )}
          {paused && <PausedJob paused={paused} />}
        </div>
        <div class="live-side">
          {zoom && (
            <Section title="1:1 zoom">
              <canvas ref={zoomRef} class="zoom-canvas" width={zoom.width} height={zoom.height}
                      style={{ width: `${zoom.width / dpr}px`, height: `${zoom.height / dpr}px` }}
                      aria-label={`The image at 1:1 from x ${zoom.x}, y ${zoom.y}`} role="img" />
              <p class="help">
                x {zoom.x}–{zoom.x + zoom.width - 1}, y {zoom.y}–{zoom.y + zoom.height - 1}: one image
                pixel per screen pixel.
              </p>
            </Section>
          )}
          {guide && <GuideCard guide={guide} operator={operator} />}
          <ExposureCard operator={operator} live={stream.kind === "live"} frameExposureS={shown?.exposureS} />
          <Histograms shown={shown} source={source} setSource={setSource} />
        </div>
      </div>
    </div>
  );
}

function StreamLine({ stream, now, onRetry }: { stream: StreamState; now: number; onRetry: () => void }) {
  switch (stream.kind) {
    case "connecting":
      return <p role="status"><Badge tone="idle">Connecting</Badge> to the preview stream…</p>;
    case "live":
      return <p role="status"><Badge tone="ok">Live</Badge></p>;
    case "paused":
      return (
        <p role="status">
          <Badge tone="warn">Paused</Badge> for{" "}
          <a href={href("jobs", String(stream.jobId))}>capture job {String(stream.jobId)}</a>: {stream.reason}
        </p>
      );
    case "refused":
      return <div role="status"><ErrorBox error={stream.error} /></div>;
    case "retrying": {
      const seconds = Math.max(0, Math.ceil((stream.retryAt - now) / 1000));
      // Not a live region: the countdown would be read out every second
      // (the ErrorBox is an alert by itself).
      return (
        <div>
          {stream.error && <ErrorBox error={stream.error} />}
          <p class="row">
            {stream.ended && <><Badge tone="idle">Stopped</Badge> The stream ended: {stream.ended}.</>}
            {" "}Trying again in {seconds} s.
            <button type="button" class="secondary" onClick={onRetry}>Retry now</button>
          </p>
        </div>
      );
    }
  }
}

function PausedJob({ paused }: { paused: Extract<StreamState, { kind: "paused" }> }) {
  const job = paused.job;
  if (!job) return null;
  const p = job.progress;
  return (
    <p class="help">
      Job {String(job.id)} ({job.session}): {JobState[job.state].toLowerCase()}
      {p && p.total > 0n && <> · {String(p.done)} of {String(p.total)}</>}
      {p?.step && <> · {p.step}</>}
      {job.suspensionReason && <> · suspended: {job.suspensionReason}</>}
    </p>
  );
}

function GuideBadge({ guide }: { guide: CalibrationGuide }) {
  return (
    <div class="guide-badge" aria-hidden="true">
      {guide.boardFound ? "✔ Board found" : "✖ Board not found"} · pose {guide.pose} of {guide.poses}
    </div>
  );
}

function Coverage({ label, value }: { label: string; value: number }) {
  return (
    <div class="coverage">
      <span>{label}: <strong>{(value * 100).toFixed(1)} %</strong></span>
      <meter min={0} max={1} value={value} aria-label={label} />
    </div>
  );
}

function GuideCard({ guide, operator }: { guide: CalibrationGuide; operator: boolean }) {
  const [error, setError] = useState<string | undefined>(undefined);
  const [busy, setBusy] = useState(false);
  const go = async () => {
    setBusy(true);
    setError(undefined);
    try {
      await api.jobs.continue({ jobId: guide.jobId });
    } catch (e) {
      setError(errorMessage(e));
    } finally {
      setBusy(false);
    }
  };
  return (
    <Section title="Calibration">
      <p>
        <a href={href("jobs", String(guide.jobId))}>Job {String(guide.jobId)}</a> waits for pose{" "}
        <strong>{guide.pose} of {guide.poses}</strong>; {guide.posesKept} kept so far.
      </p>
      <p>
        {guide.boardFound
          ? <Badge tone="ok">Board found</Badge>
          : <><Badge tone="bad">Board not found</Badge> {guide.boardMissing}</>}
      </p>
      <Coverage label="Coverage, left view" value={guide.coverageLeft} />
      <Coverage label="Coverage, right view" value={guide.coverageRight} />
      <Coverage label="Left with this pose" value={guide.coverageWithThisPose} />
      {operator && (
        <p>
          <button type="button" onClick={go} disabled={busy}>Continue: take pose {guide.pose}</button>
        </p>
      )}
      <ErrorBox error={error} />
    </Section>
  );
}

function formatName(v: string | undefined): string {
  return v ? v.toLowerCase().replace(/_/g, " ") : "–";
}

function describeSettings(s: CameraSettings): string {
  return [
    formatExposure(s.exposureS),
    s.iso > 0 ? `ISO ${s.iso}` : "ISO unchanged",
    s.apertureF > 0 ? `f/${s.apertureF}` : "aperture unchanged",
  ].join(", ");
}

// The camera's settings, read each time the stream goes live (while a
// capture holds the rig the daemon refuses to read them).
function ExposureCard({ operator, live, frameExposureS }: {
  operator: boolean; live: boolean; frameExposureS?: number;
}) {
  const [current, setCurrent] = useState<CameraSettings | undefined>(undefined);
  const [loadError, setLoadError] = useState<string | undefined>(undefined);
  const [exposure, setExposure] = useState("");
  const [iso, setIso] = useState("");
  const [aperture, setAperture] = useState("");
  const [applied, setApplied] = useState<CameraSettings | undefined>(undefined);
  const [error, setError] = useState<string | undefined>(undefined);
  const [busy, setBusy] = useState(false);

  const show = (s: CameraSettings) => {
    setCurrent(s);
    setExposure(formatExposure(s.exposureS, { forInput: true }));
    setIso(s.iso > 0 ? String(s.iso) : "");
    setAperture(s.apertureF > 0 ? String(s.apertureF) : "");
  };
  useEffect(() => {
    if (!live) return;
    let alive = true;
    api.hardware.getCameraSettings({}).then(
      (s) => { if (alive) { show(s); setLoadError(undefined); } },
      (e) => { if (alive) setLoadError(errorMessage(e)); });
    return () => { alive = false; };
  }, [live]);

  const exposureS = parseExposure(exposure);
  const submit = async (e: Event) => {
    e.preventDefault();
    if (exposureS === undefined) return;
    setBusy(true);
    setError(undefined);
    try {
      const used = await api.hardware.setCameraSettings({
        settings: { exposureS, iso: Number(iso) || 0, apertureF: Number(aperture) || 0 },
      });
      setApplied(used);
      show(used);
    } catch (err) {
      setError(errorMessage(err));
    } finally {
      setBusy(false);
    }
  };

  return (
    <Section title="Exposure">
      <ErrorBox error={loadError} />
      {!current && !loadError && <p class="muted">Read when live view runs.</p>}
      {current && (
        <dl class="facts">
          <dt>Exposure</dt><dd>{formatExposure(current.exposureS)}</dd>
          {frameExposureS !== undefined && <><dt>This frame</dt><dd>{formatExposure(frameExposureS)}</dd></>}
          <dt>ISO</dt><dd>{current.iso > 0 ? current.iso : "–"}</dd>
          <dt>Aperture</dt><dd>{current.apertureF > 0 ? `f/${current.apertureF}` : "–"}</dd>
          <dt>Format</dt><dd>{formatName(ImageFormat[current.format])}</dd>
          <dt>Stored in</dt><dd>{formatName(CameraSettings_CaptureTarget[current.captureTarget])}</dd>
        </dl>
      )}
      {operator && current && (
        <form class="exposure-form" onSubmit={submit}>
          <div class="field">
            <label for="exp-time">Exposure time</label>
            <input id="exp-time" value={exposure} onInput={(e) => setExposure(e.currentTarget.value)}
                   aria-invalid={exposureS === undefined ? "true" : undefined}
                   aria-describedby="exp-time-help" inputMode="decimal" />
            <p id="exp-time-help" class="help">Seconds or a fraction, e.g. 1/125 or 0.5.</p>
          </div>
          <div class="row">
            <div class="field">
              <label for="exp-iso">ISO</label>
              <input id="exp-iso" type="number" min={0} step={1} value={iso} placeholder="unchanged"
                     onInput={(e) => setIso(e.currentTarget.value)} />
            </div>
            <div class="field">
              <label for="exp-aperture">Aperture (f-number)</label>
              <input id="exp-aperture" type="number" min={0} step="any" value={aperture} placeholder="unchanged"
                     onInput={(e) => setAperture(e.currentTarget.value)} />
            </div>
          </div>
          <button type="submit" disabled={busy || exposureS === undefined}>Apply</button>
          {applied && (
            <p role="status" class="help">The camera uses: {describeSettings(applied)}.</p>
          )}
          <ErrorBox error={error} />
        </form>
      )}
    </Section>
  );
}

const kChannelClass: Record<string, string> = { red: "red", green: "green", blue: "blue", gray: "gray" };

function histogramJson(sequence: bigint, channels: ChannelHistogram[]): string {
  return JSON.stringify({ sequence: Number(sequence), channels });
}

function Histograms({ shown, source, setSource }: {
  shown?: Shown; source: "server" | "browser"; setSource: (s: "server" | "browser") => void;
}) {
  const channels = shown ? (source === "server" ? shown.server : shown.browser) : [];
  return (
    <Section title="Histograms">
      <fieldset class="row histogram-source">
        <legend>Computed by</legend>
        <label class="check">
          <input type="radio" name="hist-source" checked={source === "server"} onChange={() => setSource("server")} />
          the daemon
        </label>
        <label class="check">
          <input type="radio" name="hist-source" checked={source === "browser"} onChange={() => setSource("browser")} />
          this browser
        </label>
      </fieldset>
      <p class="help">
        {shown
          ? source === "server"
            ? `The daemon's statistics of frame #${shown.sequence}, sent with it.`
            : `Computed here from the decoded pixels of frame #${shown.sequence}.`
          : "Waiting for a frame."}{" "}
        Counts on a log scale; lines at the 1st, 50th and 99th percentiles.
      </p>
      <div class="histograms"
           data-histogram={shown ? histogramJson(shown.sequence, shown.browser) : undefined}
           data-server-histogram={shown ? histogramJson(shown.sequence, shown.server) : undefined}>
        {channels.map((c) => <HistogramChart key={c.channel} c={c} />)}
      </div>
    </Section>
  );
}

const kChartHeight = 60;

function HistogramChart({ c }: { c: ChannelHistogram }) {
  const name = c.channel.charAt(0).toUpperCase() + c.channel.slice(1);
  const summary = `p1 ${c.p1} · p50 ${c.p50} · p99 ${c.p99} · mean ${c.mean.toFixed(1)} · ` +
    `clipped low ${percent(c.clippedLow)} · high ${percent(c.clippedHigh)}`;
  const marks: [string, number, string][] = [["p1", c.p1, "mark-p1"], ["p50", c.p50, "mark-p50"], ["p99", c.p99, "mark-p99"]];
  return (
    <figure class="histogram">
      <figcaption><strong>{name}</strong>: {summary}</figcaption>
      <div class="histogram-plot">
        <svg viewBox={`0 0 ${kLevels} ${kChartHeight}`} preserveAspectRatio="none" role="img"
             aria-label={`${name} histogram: ${summary}`}>
          <path d={histogramPath(c.histogram, kChartHeight)} class={`hist-${kChannelClass[c.channel] ?? "gray"}`} />
          {marks.map(([label, v, cls]) => (
            <line key={label} x1={v + 0.5} x2={v + 0.5} y1={0} y2={kChartHeight} class={cls}
                  vector-effect="non-scaling-stroke" />
          ))}
        </svg>
        <div class="histogram-marks" aria-hidden="true">
          {marks.map(([label, v, cls]) => (
            <span key={label} class={cls} style={{ left: `${((v + 0.5) / kLevels) * 100}%` }}>{label} {v}</span>
          ))}
        </div>
      </div>
    </figure>
  );
}
