// SPDX-License-Identifier: GPL-3.0-or-later
//
// A dropped connection during a capture, in Chromium over TLS: the browser
// reaches the edge through a CONNECT proxy of this test, which cuts every
// connection (the job's event stream included) while the job page follows
// a running structured-light capture (simulated hardware at a quarter of
// real time) and refuses new ones for a few seconds; the page says it lost the
// connection, reconnects, and its event log ends with every event of the
// job exactly once, in order, as the API lists them.
import assert from "node:assert/strict";
import { createServer, type Server } from "node:http";
import { connect, type Socket } from "node:net";
import type { AddressInfo } from "node:net";
import { after, before, test } from "node:test";
import type { Browser } from "playwright-core";
import { type ApiKey, closeAll, Daemon, inspect, kSmallLabLamp, launchBrowser, screenshot, signIn,
         stopCleanly, until, withConsole } from "./harness.ts";

let daemon: Daemon;
let browser: Browser;
let operator: ApiKey;
let proxy: Server;
const tunnels = new Set<Socket>();
let down = false;
const kSession = "drop-1";

// An HTTP CONNECT proxy on 127.0.0.1 that pipes TLS through untouched, so
// the page's URL, Host and Origin stay the edge's own.
async function startProxy(): Promise<string> {
  proxy = createServer((_req, res) => {
    res.writeHead(405);
    res.end();
  });
  proxy.on("connect", (req, client: Socket, head: Buffer) => {
    const [host, port] = (req.url ?? "").split(":");
    if (down || host !== "127.0.0.1") {
      client.destroy();
      return;
    }
    const server = connect(Number(port), host, () => {
      client.write("HTTP/1.1 200 Connection Established\r\n\r\n");
      if (head.length > 0) server.write(head);
      server.pipe(client);
      client.pipe(server);
    });
    for (const s of [client, server]) {
      tunnels.add(s);
      s.on("error", () => undefined);
      s.on("close", () => {
        tunnels.delete(s);
        client.destroy();
        server.destroy();
      });
    }
  });
  await new Promise<void>((r) => proxy.listen(0, "127.0.0.1", () => r()));
  return `http://127.0.0.1:${(proxy.address() as AddressInfo).port}`;
}

before(async () => {
  daemon = await Daemon.start({ scenePatch: kSmallLabLamp,
                                extraArgs: ["--sim-time-scale", "0.25"] });
  const proxyUrl = await startProxy();
  // Loopback goes through the proxy too (Chromium bypasses it by default).
  browser = await launchBrowser(daemon.spkiHash,
                                [`--proxy-server=${proxyUrl}`, "--proxy-bypass-list=<-loopback>"]);
  operator = await daemon.createKey("operator");
  await daemon.ok("Sessions/Create", { name: kSession }, operator);
}, { timeout: 120_000 });

after(async () => {
  await closeAll([
    () => browser?.close(),
    () => {
      for (const s of tunnels) s.destroy();
      proxy?.close();
    },
    () => stopCleanly(daemon),
  ]);
}, { timeout: 60_000 });

test("the job view resumes after a dropped connection with no event missing or repeated",
     { timeout: 300_000 }, async () => {
  await withConsole(browser, daemon, "reconnect", async (c) => {
    const { page } = c;
    await signIn(c, operator);
    const job = await daemon.ok("Jobs/SubmitCapture",
                                { session: kSession, plan: { structuredLight: {} } }, operator);
    await page.goto(`/#/jobs/${job.id}`);
    const rows = page.locator("li[data-sequence]");
    await until(60_000, "the first events on the page", async () =>
      (await rows.count()) >= 3 ? true : undefined);
    const before = await rows.count();

    // The drop: every connection cut, new ones refused for a few seconds;
    // the page's requests meanwhile fail at the network level.
    c.watch.allow(/./, 0, /^net::ERR_[A-Z_]+$/);
    down = true;
    for (const s of tunnels) s.destroy();
    await page.getByText(/connection lost/).waitFor({ timeout: 30_000 });
    await screenshot(page, "reconnect-dropped");
    const during = await daemon.ok("Jobs/Get", { jobId: job.id }, operator);
    await page.waitForTimeout(3000);
    down = false;

    await page.getByText("complete: the job has ended").waitFor({ timeout: 240_000 });
    const done = await daemon.ok("Jobs/Get", { jobId: job.id }, operator);
    assert.equal(done.state, "JOB_STATE_SUCCEEDED", JSON.stringify(done));
    const shown = await rows.evaluateAll(
      (list) => list.map((r) => Number(r.getAttribute("data-sequence"))));
    const events = await daemon.stream("Jobs/Watch", { jobId: job.id }, operator);
    assert.deepEqual(shown, events.map((e) => Number(e.sequence)));
    // The drop was real: the job went on while the page was cut off.
    assert.equal(during.state, "JOB_STATE_RUNNING", "the capture ended before the drop");
    assert.ok(shown.length > before, `${before} events before the drop, ${shown.length} after`);
    await inspect(page, "reconnect-resumed");
  });
});
