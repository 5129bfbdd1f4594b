// SPDX-License-Identifier: GPL-3.0-or-later
//
// The radiance map (hdr/im0.pfm, im1.pfm) with an exposure slider: the map
// goes to the GPU once as a float texture and each slider step is one
// draw of a shader that multiplies by 2^EV and applies the sRGB curve
// (hdr_tone.ts), so a step costs a frame, not a trip to the server. Each
// redraw is timed (draw, finish and one pixel read back, which waits for
// the GPU) and shown; the canvas carries data-redraw-ms (last) and
// data-redraw-max-ms for the browser test. Without WebGL2, for a map larger
// than the GPU's textures or when the upload fails, the same curve runs on
// the CPU into a 2D canvas. The GPU's objects and context are released on
// unmount.
import { useEffect, useRef, useState } from "preact/hooks";
import {
  autoExposureEv, drawSize, kHdrFragmentShader, kHdrVertexShader, toneInto,
} from "../hdr_tone";
import type { Pfm } from "../pfm";
import { formatBytes } from "../ui";
import { usePfm } from "./load_pfm";

interface Renderer {
  kind: string;               // said on the page: what draws
  draw: (ev: number) => void;
  // Draws into width x height from now on (WebGL: the size it is shown at).
  resize?: (width: number, height: number) => void;
  dispose: () => void;
}

function compile(gl: WebGL2RenderingContext, type: number, source: string,
                 made: WebGLShader[]): WebGLShader {
  const shader = gl.createShader(type);
  if (!shader) throw new Error("the context gives no shader");
  made.push(shader);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(`shader: ${gl.getShaderInfoLog(shader) ?? "does not compile"}`);
  }
  return shader;
}

// A WebGL2 renderer, or why there is none (the 2D canvas draws then): no
// WebGL2, a map larger than the GPU's textures, a failed upload. Whatever
// it made is deleted and its context released when it cannot draw, and
// on dispose().
function webglRenderer(canvas: HTMLCanvasElement, pfm: Pfm): Renderer | string {
  const gl = canvas.getContext("webgl2", { antialias: false, depth: false, alpha: false });
  if (!gl) return "no WebGL2 here";
  const shaders: WebGLShader[] = [];
  let program: WebGLProgram | null = null;
  let texture: WebGLTexture | null = null;
  let vao: WebGLVertexArrayObject | null = null;
  const release = () => {
    gl.deleteVertexArray(vao);
    gl.deleteTexture(texture);
    gl.deleteProgram(program);
    for (const shader of shaders) gl.deleteShader(shader);
    gl.getExtension("WEBGL_lose_context")?.loseContext();
  };
  const maxSize = Number(gl.getParameter(gl.MAX_TEXTURE_SIZE));
  if (pfm.width > maxSize || pfm.height > maxSize) {
    release();
    return `the map is larger than this GPU's textures of at most ${maxSize}×${maxSize}`;
  }
  try {
    program = gl.createProgram();
    if (!program) throw new Error("the context gives no program");
    gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, kHdrVertexShader, shaders));
    gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, kHdrFragmentShader, shaders));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
      throw new Error(`shader program: ${gl.getProgramInfoLog(program) ?? "does not link"}`);
    }
    let rgb = pfm.data;
    if (pfm.channels === 1) {
      rgb = new Float32Array(pfm.data.length * 3);
      for (let i = 0; i < pfm.data.length; ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = pfm.data[i];
    }
    texture = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, texture);
    // NEAREST: float textures need an extension only for linear filtering.
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGB32F, pfm.width, pfm.height, 0, gl.RGB, gl.FLOAT, rgb);
    const error = gl.getError();
    if (error !== gl.NO_ERROR) throw new Error(`the float texture's upload failed (GL error ${error})`);
    vao = gl.createVertexArray();
  } catch (e) {
    release();
    return `WebGL2 could not take the map: ${e instanceof Error ? e.message : String(e)}`;
  }
  gl.useProgram(program);
  gl.uniform1i(gl.getUniformLocation(program, "radiance"), 0);
  const gain = gl.getUniformLocation(program, "gain");
  const scale = gl.getUniformLocation(program, "scale");
  const resize = (width: number, height: number) => {
    canvas.width = width;
    canvas.height = height;
    gl.viewport(0, 0, width, height);
    gl.uniform2f(scale, pfm.width / width, pfm.height / height);
  };
  resize(pfm.width, pfm.height);
  gl.bindVertexArray(vao);
  const probe = new Uint8Array(4);
  const info = gl.getExtension("WEBGL_debug_renderer_info");
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
  return {
    kind: `WebGL2, float texture${name ? ` (${name})` : ""}`,
    draw: (ev) => {
      gl.uniform1f(gain, Math.pow(2, ev));
      gl.drawArrays(gl.TRIANGLES, 0, 3);
      // Chromium's finish() returns before the GPU process has drawn (0 ms
      // under SwiftShader); reading a pixel back waits until it has.
      gl.finish();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, probe);
    },
    resize,
    dispose: release,
  };
}

// `why`: why WebGL2 does not draw, said on the page.
function canvasRenderer(canvas: HTMLCanvasElement, pfm: Pfm, why: string): Renderer {
  const ctx = canvas.getContext("2d");
  if (!ctx) throw new Error("this browser gives neither a WebGL2 nor a 2D canvas");
  let image = ctx.createImageData(pfm.width, pfm.height);
  return {
    kind: `2D canvas (${why}): the curve runs on the CPU`,
    draw: (ev) => {
      toneInto(pfm.data, pfm.channels, pfm, ev, image.data, image);
      ctx.putImageData(image, 0, 0);
    },
    resize: (width, height) => {
      canvas.width = width;
      canvas.height = height;
      image = ctx.createImageData(width, height);
    },
    dispose: () => {},
  };
}

export function HdrViewer({ url, label }: { url: string; label: string }) {
  const { pfm, error, bytes } = usePfm(url);
  const canvasRef = useRef<HTMLCanvasElement>(null);
  const rendererRef = useRef<Renderer | null>(null);
  const [ev, setEv] = useState(0);
  const [autoEv, setAutoEv] = useState(0);
  const [kind, setKind] = useState("");
  const [timing, setTiming] = useState<{ last: number; max: number; count: number }>(
    { last: 0, max: 0, count: 0 });
  const [renderError, setRenderError] = useState<string | undefined>(undefined);
  // Why WebGL2 does not draw this map: the 2D renderer then draws into a
  // fresh canvas (one that had a WebGL context gives no 2D one).
  const [fallback, setFallback] = useState<{ pfm: Pfm; why: string } | undefined>(undefined);
  const noWebgl = pfm && fallback?.pfm === pfm ? fallback.why : undefined;
  const maxRef = useRef(0);
  const countRef = useRef(0);
  const evRef = useRef(0);

  const redraw = (value: number) => {
    const renderer = rendererRef.current;
    const canvas = canvasRef.current;
    if (!renderer || !canvas) return;
    const start = performance.now();
    renderer.draw(value);
    const ms = performance.now() - start;
    maxRef.current = Math.max(maxRef.current, ms);
    countRef.current += 1;
    canvas.dataset.redrawMs = ms.toFixed(2);
    canvas.dataset.redrawMaxMs = maxRef.current.toFixed(2);
    canvas.dataset.redraws = String(countRef.current);
    canvas.dataset.ev = String(value);
    evRef.current = value;
    setTiming({ last: ms, max: maxRef.current, count: countRef.current });
  };

  useEffect(() => {
    const canvas = canvasRef.current;
    if (!pfm || !canvas) return;
    canvas.width = pfm.width;
    canvas.height = pfm.height;
    let renderer: Renderer;
    try {
      const webgl = noWebgl === undefined ? webglRenderer(canvas, pfm) : noWebgl;
      if (typeof webgl === "string" && noWebgl === undefined) {
        setFallback({ pfm, why: webgl });
        return;
      }
      renderer = typeof webgl === "string" ? canvasRenderer(canvas, pfm, webgl) : webgl;
    } catch (e) {
      setRenderError(e instanceof Error ? e.message : String(e));
      return;
    }
    rendererRef.current = renderer;
    setKind(renderer.kind);
    canvas.dataset.renderer = renderer.kind.startsWith("WebGL2") ? "webgl2" : "2d";
    const start = autoExposureEv(pfm.data, pfm.channels);
    setAutoEv(start);
    setEv(start);
    // The first draw also finishes the texture's upload: timed on its own,
    // so the slider's figures are steps only.
    const first = performance.now();
    renderer.draw(start);
    canvas.dataset.firstDrawMs = (performance.now() - first).toFixed(2);
    maxRef.current = 0;
    countRef.current = 0;
    redraw(start);
    // Both renderers draw at the size the map is shown (the screen's
    // pixels, at most the map's): each slider step then shades only what
    // is seen.
    const fit = renderer.resize;
    const observer = fit && typeof ResizeObserver !== "undefined"
      ? new ResizeObserver(() => {
        const size = drawSize(pfm.width, pfm.height, canvas.clientWidth, window.devicePixelRatio || 1);
        if (size.width === canvas.width && size.height === canvas.height) return;
        fit(size.width, size.height);
        canvas.dataset.drawSize = `${size.width}x${size.height}`;
        // Not a slider step: the first draw into a new buffer allocates it.
        renderer.draw(evRef.current);
      })
      : undefined;
    observer?.observe(canvas);
    canvas.dataset.drawSize = `${canvas.width}x${canvas.height}`;
    return () => {
      observer?.disconnect();
      renderer.dispose();
      rendererRef.current = null;
    };
  }, [pfm, noWebgl]);

  const lo = Math.floor(autoEv) - 8;
  const hi = Math.floor(autoEv) + 8;
  return (
    <div class="hdr-viewer">
      {error && <p class="error" role="alert"><strong>Error:</strong> {error}</p>}
      {renderError && <p class="error" role="alert"><strong>Error:</strong> {renderError}</p>}
      {!pfm && !error && <p class="muted" role="status">Loading the radiance map…</p>}
      {pfm && (
        <div class="viewer-controls row">
          <label for="hdr-ev">Exposure</label>
          <input id="hdr-ev" type="range" min={lo} max={hi} step={0.1} value={ev}
                 aria-valuetext={`${ev >= 0 ? "+" : ""}${ev.toFixed(1)} EV`}
                 onInput={(e) => {
                   const v = Number(e.currentTarget.value);
                   setEv(v);
                   redraw(v);
                 }} />
          <output for="hdr-ev" class="mono" data-testid="hdr-ev">
            {ev >= 0 ? "+" : ""}{ev.toFixed(1)} EV (×{Math.pow(2, ev).toPrecision(3)})
          </output>
          <button type="button" class="secondary" onClick={() => { setEv(autoEv); redraw(autoEv); }}>
            Auto ({autoEv >= 0 ? "+" : ""}{autoEv.toFixed(1)} EV)
          </button>
          <span class="mono" data-testid="hdr-redraw" aria-live="off">
            redraw {timing.last.toFixed(1)} ms (max {timing.max.toFixed(1)} ms over {timing.count})
          </span>
        </div>
      )}
      <div class="hdr-stage"
           style={pfm ? { maxWidth: `min(100%, calc((100vh - 18rem) * ${pfm.width / pfm.height}))` } : undefined}>
        {/* A new map or renderer gets a new canvas: a released context stays
            with its canvas. */}
        <canvas ref={canvasRef} key={`${url} ${noWebgl === undefined ? "webgl" : "2d"}`}
                class="viewer-canvas hdr-canvas" hidden={!pfm}
                aria-label={`${label}: radiance map shown at the chosen exposure`} role="img" />
      </div>
      {pfm && (
        <p class="help">
          {pfm.width}×{pfm.height}, {pfm.channels === 3 ? "RGB" : "grey"} float
          ({formatBytes(bytes ?? 0)}, {pfm.littleEndian ? "little" : "big"}-endian PFM).
          Linear radiance × 2<sup>EV</sup>, clipped at white, sRGB curve. Drawn by {kind}, at the size it is shown (the screen's pixels, at most the map's).
          Auto puts the 99th percentile of luminance at white.
        </p>
      )}
    </div>
  );
}
