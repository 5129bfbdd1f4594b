// SPDX-License-Identifier: GPL-3.0-or-later
//
// The operator's walkthrough in Chromium over TLS, against the real daemon
// on simulated hardware: sign in; live view shows frames whose histogram,
// computed in the browser from the decoded frame, agrees with the daemon's
// frame statistics of the same frame within one bin; take and release the
// rig lock; capture bracketed stereo and structured light from the Capture
// page and follow both to the end on the job page (every event once, in
// order); process; the metrics table equals the API's; the HDR viewer's
// slider redraws (timed, not limited); the fused disparity read at three pixels equals
// the PFM artifact downloaded here. Then the main pages at tablet width
// (800 px): none wider than the screen. Every page: no console error, no
// failed request, no serious axe-core violation, a screenshot.
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import type { Browser, Page } from "playwright-core";
import { type ApiKey, closeAll, Daemon, inspect, kSmallLabLamp, launchBrowser, signIn,
         stopCleanly, until, withConsole } from "./harness.ts";
import { parsePfm, pfmValue } from "./pfm.ts";

let daemon: Daemon;
let browser: Browser;
let operator: ApiKey;
const kSession = "walk-1";

before(async () => {
  daemon = await Daemon.start({ scenePatch: kSmallLabLamp });
  browser = await launchBrowser(daemon.spkiHash);
  operator = await daemon.createKey("operator");
}, { timeout: 120_000 });

after(async () => {
  await closeAll([() => browser?.close(), () => stopCleanly(daemon)]);
}, { timeout: 60_000 });

interface Histogram {
  channel: string;
  histogram: number[];
  p1: number;
  p50: number;
  p99: number;
}

// The two histograms agree within one bin: each percentile within one
// level, and the browser's cumulative count at every level lies between
// the daemon's at the levels either side.
function agreeWithinOneBin(browser: Histogram, server: Histogram): string | undefined {
  for (const p of ["p1", "p50", "p99"] as const) {
    if (Math.abs(browser[p] - server[p]) > 1) {
      return `${browser.channel} ${p}: browser ${browser[p]}, daemon ${server[p]}`;
    }
  }
  const cumulative = (h: number[]) => h.reduce<number[]>((a, v) => [...a, (a.at(-1) ?? 0) + v], []);
  const b = cumulative(browser.histogram);
  const s = cumulative(server.histogram);
  if (b.at(-1) !== s.at(-1)) return `${browser.channel}: ${b.at(-1)} pixels vs ${s.at(-1)}`;
  for (let v = 0; v < 256; ++v) {
    const low = s[Math.max(0, v - 1)];
    const high = s[Math.min(255, v + 1)];
    if (b[v] < low || b[v] > high) {
      return `${browser.channel} level ${v}: browser's cumulative ${b[v]} not within the ` +
             `daemon's ${low}..${high}`;
    }
  }
  return undefined;
}

// The job page of the job just submitted: waits for its end and checks that
// its event log lists exactly the API's events, once each, in order.
async function followJob(page: Page, screenshotName: string): Promise<string> {
  await page.waitForURL(/#\/jobs\/\d+$/);
  const jobId = /#\/jobs\/(\d+)$/.exec(page.url())![1];
  await page.getByRole("heading", { level: 1, name: new RegExp(`^Job #${jobId}`) }).waitFor();
  await page.getByText("complete: the job has ended").waitFor({ timeout: 120_000 });
  const job = await daemon.ok("Jobs/Get", { jobId }, operator);
  assert.equal(job.state, "JOB_STATE_SUCCEEDED", JSON.stringify(job));
  await page.getByRole("heading", { level: 1, name: /succeeded/ }).waitFor();
  const shown = await page.locator("li[data-sequence]").evaluateAll(
    (rows) => rows.map((r) => Number(r.getAttribute("data-sequence"))));
  const events = await daemon.stream("Jobs/Watch", { jobId }, operator);
  assert.deepEqual(shown, events.map((e) => Number(e.sequence)), `job ${jobId}'s event log`);
  await inspect(page, screenshotName);
  return jobId;
}

async function submitCapture(page: Page, kind: "Bracketed stereo" | "Structured light",
                             newSession?: string): Promise<void> {
  await page.getByRole("navigation", { name: "Pages" }).getByRole("link", { name: "Capture" })
    .click();
  await page.getByRole("heading", { level: 1, name: "Capture" }).waitFor();
  const session = page.getByRole("combobox", { name: "Session", exact: true });
  if (newSession) {
    await session.selectOption({ label: "New session…" });
    await page.getByLabel("New session's name").fill(newSession);
  } else {
    await session.selectOption({ value: kSession });
  }
  await page.getByRole("radio", { name: kind }).check();
  // The daemon's estimate of the plan, before submitting.
  await until(30_000, "the capture estimate", async () => {
    const frames = await page.getByTestId("estimate-frames").textContent({ timeout: 1000 });
    return frames && Number(frames) > 0 ? frames : undefined;
  });
  await inspect(page, kind === "Bracketed stereo" ? "capture-stereo" : "capture-structured-light");
  await page.getByRole("button", { name: "Submit capture" }).click();
}

test("the operator's walkthrough", { timeout: 480_000 }, async () => {
  await withConsole(browser, daemon, "walkthrough", async (c) => {
    const { page } = c;
    await signIn(c, operator);
    assert.equal(await page.getByTestId("who").textContent(), "alice (operator)");

    // Rig: take the lock, then release it.
    await page.getByRole("heading", { level: 1, name: "Rig" }).waitFor();
    await page.getByText("hdrstereo simulated camera").first().waitFor();
    await page.getByLabel("Why (shown to people refused)").fill("walkthrough: focusing");
    await page.getByRole("button", { name: "Take the lock" }).click();
    await page.getByRole("button", { name: "Release", exact: true }).waitFor();
    const held = await daemon.ok("Hardware/GetLock", {}, operator);
    assert.equal(held.holder, "alice", JSON.stringify(held));
    assert.equal(held.note, "walkthrough: focusing");
    await inspect(page, "rig-locked");
    await page.getByRole("button", { name: "Release", exact: true }).click();
    await page.getByRole("button", { name: "Take the lock" }).waitFor();
    const released = await daemon.ok("Hardware/GetLock", {}, operator);
    assert.ok(!released.holder, JSON.stringify(released));

    // Live view: three frames, each histogram against the daemon's.
    await page.getByRole("navigation", { name: "Pages" }).getByRole("link", { name: "Live view" })
      .click();
    await page.getByRole("heading", { level: 1, name: "Live view" }).waitFor();
    const checked = new Set<number>();
    await until(60_000, "three live-view frames checked", async () => {
      const both = await page.locator("[data-histogram][data-server-histogram]").evaluate((e) => ({
        browser: e.getAttribute("data-histogram")!, server: e.getAttribute("data-server-histogram")!,
      }));
      const browserSide = JSON.parse(both.browser);
      const serverSide = JSON.parse(both.server);
      assert.equal(browserSide.sequence, serverSide.sequence);
      if (!checked.has(browserSide.sequence)) {
        assert.equal(browserSide.channels.length, serverSide.channels.length);
        assert.ok(serverSide.channels.length >= 1);
        for (let i = 0; i < serverSide.channels.length; ++i) {
          const problem = agreeWithinOneBin(browserSide.channels[i], serverSide.channels[i]);
          assert.equal(problem, undefined, `frame ${browserSide.sequence}: ${problem}`);
        }
        checked.add(browserSide.sequence);
      }
      return checked.size >= 3 ? true : undefined;
    }, 200);
    const canvasSequence = Number(await page.locator("canvas[data-sequence]").getAttribute("data-sequence"));
    assert.ok(canvasSequence >= 3, `live view shows frame ${canvasSequence}`);
    await inspect(page, "live");

    // Captures, each followed on its job page to the end.
    await submitCapture(page, "Bracketed stereo", kSession);
    await followJob(page, "job-stereo");
    await submitCapture(page, "Structured light");
    await followJob(page, "job-structured-light");

    // Process from the session's page, then follow the job.
    await page.getByRole("navigation", { name: "Pages" }).getByRole("link", { name: "Sessions" })
      .click();
    await page.getByRole("heading", { level: 1, name: "Sessions" }).waitFor();
    await page.getByRole("link", { name: kSession, exact: true }).click();
    await page.getByRole("heading", { level: 1, name: `Session ${kSession}` }).waitFor();
    await page.getByRole("button", { name: /^Process this session/ }).click();
    await page.getByRole("link", { name: "follow it on the Jobs page" }).click();
    await followJob(page, "job-processing");

    // The session's results: the metrics table equals the API's.
    await page.goto(`/#/sessions/${kSession}`);
    await page.getByRole("heading", { level: 1, name: `Session ${kSession}` }).waitFor();
    const table = page.getByTestId("metrics-table");
    await table.waitFor();
    const shownMetrics = await table.locator("tbody tr").evaluateAll((rows) => rows.map((r) => ({
      truth: r.getAttribute("data-truth"), method: r.getAttribute("data-method"),
      values: Array.from(r.querySelectorAll("td[data-value]"))
        .map((td) => Number(td.getAttribute("data-value"))),
      worse: r.querySelector("td[data-worse-than-ldr]")?.getAttribute("data-worse-than-ldr") === "true",
    })));
    const api = (await daemon.ok("Sessions/ListMetrics", { session: kSession }, operator)).metrics;
    assert.ok(api.length > 0);
    assert.deepEqual(shownMetrics, api.map((m: any) => ({
      truth: m.groundTruth, method: m.method,
      values: [m.rmsePx, m.maePx, m.bad05, m.bad1, m.bad2, m.bad4, m.coverage].map((v) => v ?? 0),
      worse: m.worseThanLdr ?? false,
    })));
    await inspect(page, "session");

    const artifacts = (await daemon.ok("Sessions/ListArtifacts",
                                       { session: kSession, page: { pageSize: 1000 } },
                                       operator)).artifacts as any[];
    const artifact = (path: string) => {
      const a = artifacts.find((x) => x.path === path);
      assert.ok(a, `no artifact ${path}`);
      return a;
    };

    // The HDR viewer: 20 steps of the exposure slider, each redraw timed.
    await page.goto(`/#/sessions/${kSession}/artifacts/${artifact("hdr/im0.pfm").id}`);
    const hdr = page.locator("canvas.hdr-canvas");
    await until(30_000, "the radiance map drawn", async () =>
      Number(await hdr.getAttribute("data-redraws")) >= 1 ? true : undefined);
    const slider = page.getByRole("slider", { name: "Exposure" });
    const before = Number(await hdr.getAttribute("data-redraws"));
    const redrawMs: number[] = [];
    for (let step = 0; step < 20; ++step) {
      await slider.press(step < 10 ? "ArrowRight" : "ArrowLeft");
      await until(5_000, "a redraw", async () =>
        Number(await hdr.getAttribute("data-redraws")) >= before + step + 1 ? true : undefined, 20);
      redrawMs.push(Number(await hdr.getAttribute("data-redraw-ms")));
    }
    const maxMs = Number(await hdr.getAttribute("data-redraw-max-ms"));
    const sorted = [...redrawMs].sort((a, b) => a - b);
    console.log(`HDR slider: ${await hdr.getAttribute("data-renderer")}, redraw median ` +
                `${sorted[10]} ms, max ${maxMs} ms over 20 steps`);
    // Timed, not held to a limit here (a wall-clock limit fails on a busy
    // machine, not on a slow viewer): measure.ts times the 1200x900 map for
    // docs/benchmarks.md. Each step was a redraw, with a time.
    assert.ok(redrawMs.every((ms) => Number.isFinite(ms) && ms >= 0),
              `redraw times: ${redrawMs.join(", ")}`);
    await inspect(page, "hdr-viewer");

    // The fused disparity, read at three pixels, equals the PFM artifact.
    const fused = artifact("disparity/fused.pfm");
    const download = await daemon.fetch(`/files/sessions/${kSession}/artifacts/${fused.id}`,
                                        { headers: { Authorization: `Bearer ${operator.key}` } });
    assert.equal(download.status, 200);
    const pfm = parsePfm(download.raw);
    // The ground truth the viewer compares with: the session's
    // structured-light disp0GT.pfm.
    const truthArtifact = artifact("ground_truth/structured_light/disp0GT.pfm");
    const truthDownload = await daemon.fetch(
      `/files/sessions/${kSession}/artifacts/${truthArtifact.id}`,
      { headers: { Authorization: `Bearer ${operator.key}` } });
    assert.equal(truthDownload.status, 200);
    const truthPfm = parsePfm(truthDownload.raw);
    await page.goto(`/#/sessions/${kSession}/artifacts/${fused.id}`);
    const canvas = page.locator("canvas.viewer-canvas");
    await canvas.waitFor();
    const readout = page.locator("#disparity-readout");
    await readout.getByText(/Point at the map/).waitFor();
    const box = (await canvas.boundingBox())!;
    const pixels = [[20, 15], [Math.floor(pfm.width / 2), Math.floor(pfm.height / 2)],
                    [pfm.width - 30, pfm.height - 25]];
    for (const [x, y] of pixels) {
      await page.mouse.move(box.x + (x + 0.5) * box.width / pfm.width,
                            box.y + (y + 0.5) * box.height / pfm.height);
      await until(5_000, `the read-out at ${x},${y}`, async () =>
        (await readout.getAttribute("data-x")) === String(x) &&
        (await readout.getAttribute("data-y")) === String(y) ? true : undefined, 20);
      const shown = Number(await readout.getAttribute("data-disparity"));
      const expected = pfmValue(pfm, x, y);
      assert.ok(Object.is(shown, expected), `disparity at ${x},${y}: shown ${shown}, PFM ${expected}`);
      const truth = Number(await readout.getAttribute("data-truth"));
      const expectedTruth = pfmValue(truthPfm, x, y);
      assert.ok(Object.is(truth, expectedTruth),
                `ground truth at ${x},${y}: shown ${truth}, PFM ${expectedTruth}`);
      if (Number.isFinite(expected) && Number.isFinite(expectedTruth)) {
        assert.equal(Number(await readout.getAttribute("data-error")),
                     Math.abs(expected - expectedTruth));
      }
    }
    await inspect(page, "disparity-viewer");
  });
});

test("the main pages at tablet width: nothing wider than the screen", { timeout: 180_000 },
     async () => {
  await withConsole(browser, daemon, "tablet", async (c) => {
    const { page } = c;
    await signIn(c, operator);
    const jobs = (await daemon.ok("Jobs/List", {}, operator)).jobs as { id: string }[];
    assert.ok(jobs.length > 0, "the walkthrough left no job");
    const pages: [string, RegExp, string][] = [
      ["#/rig", /^Rig$/, "tablet-rig"],
      ["#/live", /^Live view$/, "tablet-live"],
      ["#/capture", /^Capture$/, "tablet-capture"],
      ["#/jobs", /^Jobs$/, "tablet-jobs"],
      [`#/jobs/${jobs[0].id}`, /^Job #/, "tablet-job"],
      ["#/sessions", /^Sessions$/, "tablet-sessions"],
      [`#/sessions/${kSession}`, new RegExp(`^Session ${kSession}`), "tablet-session"],
      ["#/schedules", /^Schedules$/, "tablet-schedules"],
    ];
    for (const [hash, h1, name] of pages) {
      await page.goto(`/${hash}`);
      await page.getByRole("heading", { level: 1, name: h1 }).waitFor();
      await until(15_000, `${hash} loading`, async () =>
        (await page.getByText(/^Loading…$/).count()) === 0 ? true : undefined);
      const overflow = await page.evaluate(
        () => document.documentElement.scrollWidth - document.documentElement.clientWidth);
      assert.ok(overflow <= 0, `${hash} is ${overflow} px wider than the 800 px screen`);
      await inspect(page, name);
    }
  }, { width: 800, height: 1100 });
});
