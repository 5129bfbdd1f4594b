// SPDX-License-Identifier: GPL-3.0-or-later
//
// The console's numbers for docs/benchmarks.md (not a ctest; run by hand
// from tests/web: `node --import tsx measure.ts [--wide]`), printed as JSON, against
// the real daemon on simulated hardware (the bundled lab-lamp, 1200 x 900)
// over TLS on loopback in Debian's Chromium:
//   loadMs       navigation start to the Rig page's first data (the camera's
//                model) on the screen, signed in, median of 5 loads
//   liveView     frames per second shown in the browser vs delivered by the
//                preview stream over ~10 s, and their ratio (target >= 0.9)
//   hdrSlider    redraw time of 20 exposure-slider steps of a 1200 x 900
//                radiance map (median, max; target <= 100 ms)
//   bundle       console.js as served, raw and gzip -9 bytes
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { gzipSync } from "node:zlib";
import { Daemon, kDaemon, launchBrowser, openConsole, signIn, sleep, until } from "./harness.ts";
import { parsePfm } from "./pfm.ts";

const kRuns = 5;

function median(values: number[]): number {
  const s = [...values].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
}

const daemon = await Daemon.start();
const browser = await launchBrowser(daemon.spkiHash);
try {
  const operator = await daemon.createKey("operator");
  // --wide: a 1800 x 1300 window, where the HDR viewer draws the whole
  // 1200 x 900 map at one screen pixel per map pixel.
  const c = await openConsole(browser, daemon, "measure",
                              process.argv.includes("--wide")
                                ? { width: 1800, height: 1300 }
                                : { width: 1280, height: 800 });
  await signIn(c, operator);

  // When the camera's model first shows, in the page's own clock
  // (performance.now() counts from navigation start).
  await c.context.addInitScript(() => {
    const w = window as unknown as { firstData?: number };
    new MutationObserver((_, observer) => {
      if (document.body?.innerText.includes("hdrstereo simulated camera")) {
        w.firstData = performance.now();
        observer.disconnect();
      }
    }).observe(document, { subtree: true, childList: true, characterData: true });
  });
  const loads: number[] = [];
  for (let i = 0; i < kRuns; ++i) {
    await c.page.goto("about:blank");
    await c.page.goto("/#/rig");
    loads.push(await until(30_000, "the Rig page's data", async () =>
      (await c.page.evaluate("window.firstData")) as number | undefined));
  }

  // Live view for ~10 s: the canvas counts frames received and drawn.
  await c.page.goto("/#/live");
  const canvas = c.page.locator("canvas[data-sequence]");
  await canvas.waitFor({ timeout: 30_000 });
  const counts = async () => ({
    t: Date.now(),
    received: Number(await canvas.getAttribute("data-frames-received")),
    shown: Number(await canvas.getAttribute("data-frames-shown")),
  });
  const start = await counts();
  await sleep(10_000);
  const end = await counts();
  const seconds = (end.t - start.t) / 1000;
  const delivered = (end.received - start.received) / seconds;
  const shown = (end.shown - start.shown) / seconds;

  // A 1200 x 900 radiance map: a bracketed capture and the HDR step only.
  await daemon.ok("Sessions/Create", { name: "measure" }, operator);
  const capture = await daemon.ok("Jobs/SubmitCapture",
                                  { session: "measure", plan: { bracketedStereo: {} } }, operator);
  await daemon.stream("Jobs/Watch", { jobId: capture.id }, operator, 300_000);
  const hdrJob = await daemon.ok("Jobs/SubmitProcessing", { session: "measure", steps: ["hdr"] },
                                 operator);
  await daemon.stream("Jobs/Watch", { jobId: hdrJob.id }, operator, 300_000);
  const artifacts = (await daemon.ok("Sessions/ListArtifacts",
                                     { session: "measure", page: { pageSize: 1000 } },
                                     operator)).artifacts as { id: string; path: string }[];
  const radiance = artifacts.find((a) => a.path === "hdr/im0.pfm");
  if (!radiance) throw new Error("no hdr/im0.pfm");
  await c.page.goto(`/#/sessions/measure/artifacts/${radiance.id}`);
  const hdr = c.page.locator("canvas.hdr-canvas");
  await until(60_000, "the radiance map drawn", async () =>
    Number(await hdr.getAttribute("data-redraws")) >= 1 ? true : undefined);
  const firstDrawMs = Number(await hdr.getAttribute("data-first-draw-ms"));
  const slider = c.page.getByRole("slider", { name: "Exposure" });
  const before = Number(await hdr.getAttribute("data-redraws"));
  const redraws: number[] = [];
  for (let step = 0; step < 20; ++step) {
    await slider.press(step < 10 ? "ArrowRight" : "ArrowLeft");
    await until(5_000, "a redraw", async () =>
      Number(await hdr.getAttribute("data-redraws")) >= before + step + 1 ? true : undefined, 10);
    redraws.push(Number(await hdr.getAttribute("data-redraw-ms")));
  }
  const renderer = await hdr.getAttribute("data-renderer");
  const canvasSize = await hdr.evaluate(
    (e) => `${(e as HTMLCanvasElement).width}x${(e as HTMLCanvasElement).height}`);
  const map = parsePfm((await daemon.fetch(`/files/sessions/measure/artifacts/${radiance.id}`,
                        { headers: { Authorization: `Bearer ${operator.key}` } })).raw);
  await c.context.close();

  const bundle = readFileSync(join(kDaemon, "../../share/hdrstereo/web/console.js"));
  console.log(JSON.stringify({
    loadMs: { median: Math.round(median(loads)), runs: loads.map(Math.round) },
    liveView: { seconds: Number(seconds.toFixed(1)), deliveredFps: Number(delivered.toFixed(2)),
                shownFps: Number(shown.toFixed(2)), ratio: Number((shown / delivered).toFixed(3)) },
    hdrSlider: { renderer, mapSize: `${map.width}x${map.height}`, canvasSize, firstDrawMs, medianMs: median(redraws),
                 maxMs: Math.max(...redraws), steps: redraws.length },
    bundle: { rawBytes: bundle.length, gzipBytes: gzipSync(bundle, { level: 9 }).length },
  }, null, 2));
} finally {
  await browser.close();
  await daemon.stop();
}
