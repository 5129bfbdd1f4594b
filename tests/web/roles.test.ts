// SPDX-License-Identifier: GPL-3.0-or-later
//
// Roles and cross-site requests in Chromium over TLS: a viewer sees no
// Live view, Capture or Admin page and no operator control on any page, and the same
// call forged from the viewer's page is refused naming the role needed; a
// form posted from another origin (same-site over https, cross-site over
// http) and fetches with a foreign Origin change nothing.
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { createServer as createHttpServer, type IncomingMessage, type Server,
         type ServerResponse } from "node:http";
import { createServer as createHttpsServer } from "node:https";
import type { AddressInfo } from "node:net";
import { join } from "node:path";
import { after, before, test } from "node:test";
import type { Browser, Page } from "playwright-core";
import { type ApiKey, callWithCookie, closeAll, cookieHeader, Daemon, inspect, kSmallLabLamp,
         launchBrowser, signIn, stopCleanly, until, withConsole, within } from "./harness.ts";

let daemon: Daemon;
let browser: Browser;
let viewer: ApiKey;
let operator: ApiKey;
let jobId = "";
const kSession = "roles-1";

before(async () => {
  daemon = await Daemon.start({ scenePatch: kSmallLabLamp });
  browser = await launchBrowser(daemon.spkiHash);
  viewer = await daemon.createKey("viewer");
  operator = await daemon.createKey("operator");
  // Something on every page: a session with a finished capture.
  await daemon.ok("Sessions/Create", { name: kSession, note: "for the viewer to look at" },
                  operator);
  const job = await daemon.ok("Jobs/SubmitCapture",
                              { session: kSession, plan: { bracketedStereo: {} } }, operator);
  jobId = job.id;
  const events = await daemon.stream("Jobs/Watch", { jobId }, operator);
  assert.equal(events.at(-1)?.state, "JOB_STATE_SUCCEEDED", JSON.stringify(events.at(-1)));
}, { timeout: 180_000 });

after(async () => {
  await closeAll([() => browser?.close(), () => stopCleanly(daemon)]);
}, { timeout: 60_000 });

// Buttons only an operator (or admin) may use, by the start of their
// accessible name.
const kOperatorControl =
  new RegExp(`^(${[
    "Home", "Move", "Take the lock", "Take lock", "Release", "Renew", "Force", "Submit", "Cancel",
    "Pause", "Resume", "Continue", "Process", "Measure latency", "Apply", "Show pattern", "Blank",
    "New schedule", "Create", "Delete", "Revoke", "Enable", "Disable", "Remove",
  ].join("|")})\\b`, "i");

// Waits until the page under `h1` has landed: its heading shows and no
// "Loading…" placeholder is left (bounded).
async function landed(page: Page, h1: RegExp): Promise<void> {
  await page.getByRole("heading", { level: 1, name: h1 }).waitFor();
  await until(15_000, `page ${h1} loading`, async () =>
    (await page.getByText(/^Loading…$/).count()) === 0 ? true : undefined);
  // One more poll of the page's data.
  await page.waitForTimeout(500);
}

async function operatorControls(page: Page): Promise<string[]> {
  const names: string[] = [];
  for (const button of await page.getByRole("button").all()) {
    const name = (await button.getAttribute("aria-label")) ?? (await button.innerText());
    if (kOperatorControl.test(name.trim())) names.push(name.trim());
  }
  for (const field of await page.locator("form").all()) {
    if (await field.isVisible()) names.push(`form: ${(await field.innerText()).slice(0, 60)}`);
  }
  return names;
}

async function sessionsCreated(): Promise<string[]> {
  const list = await daemon.ok("Sessions/List", {}, operator);
  return (list.sessions ?? []).map((s: { name: string }) => s.name).sort();
}

async function jobsSubmitted(): Promise<number> {
  const list = await daemon.ok("Jobs/List", {}, operator);
  return (list.jobs ?? []).length;
}

test("a viewer sees no Live view, Capture or Admin page and no operator control on any page",
     { timeout: 180_000 }, async () => {
  await withConsole(browser, daemon, "viewer", async (c) => {
    await signIn(c, viewer);
    assert.equal(await c.page.getByTestId("who").textContent(), "vera (viewer)");
    const nav = c.page.getByRole("navigation", { name: "Pages" });
    const links = (await nav.getByRole("link").allInnerTexts()).map((t) => t.trim());
    // Live view drives the camera (StreamPreview needs operator).
    assert.deepEqual(links, ["Rig", "Jobs", "Sessions", "Schedules"]);

    const pages: [string, RegExp, string][] = [
      ["#/rig", /^Rig$/, "viewer-rig"],
      ["#/jobs", /^Jobs$/, "viewer-jobs"],
      [`#/jobs/${jobId}`, /^Job #?\d+/, "viewer-job"],
      ["#/sessions", /^Sessions$/, "viewer-sessions"],
      [`#/sessions/${kSession}`, new RegExp(`^Session ${kSession}`), "viewer-session"],
      ["#/schedules", /^Schedules$/, "viewer-schedules"],
    ];
    for (const [hash, h1, name] of pages) {
      await c.page.goto(`/${hash}`);
      await landed(c.page, h1);
      assert.deepEqual(await operatorControls(c.page), [], `operator controls on ${hash}`);
      await inspect(c.page, name);
    }
    // The pages a viewer has no link to are not shown by their address
    // either: the console shows the first page instead.
    for (const hash of ["#/live", "#/capture", "#/admin"]) {
      await c.page.goto(`/${hash}`);
      await landed(c.page, /^Rig$/);
      assert.equal(
        await c.page.getByRole("heading", { level: 1, name: /Live view|Capture|Admin/ }).count(), 0);
    }
  });
});

test("the same call forged from the viewer's page is refused, naming the role it needs",
     { timeout: 120_000 }, async () => {
  const jobsBefore = await jobsSubmitted();
  await withConsole(browser, daemon, "viewer-forged-call", async (c) => {
    await signIn(c, viewer);
    c.watch.allow(/\/hdrstereo\.v1\.Jobs\/SubmitCapture$/, 403);
    const answer = await c.page.evaluate(async (session) => {
      const response = await fetch("/hdrstereo.v1.Jobs/SubmitCapture", {
        method: "POST",
        credentials: "same-origin",
        headers: { "Content-Type": "application/json" },
        body: JSON.stringify({ session, plan: { bracketedStereo: {} } }),
      });
      return { status: response.status, body: await response.json() };
    }, kSession);
    assert.equal(answer.status, 403);
    assert.equal(answer.body.code, "permission_denied");
    assert.match(answer.body.message, /\/hdrstereo\.v1\.Jobs\/SubmitCapture needs role operator/);
    assert.match(answer.body.message, /vera has viewer/);
  });
  assert.equal(await jobsSubmitted(), jobsBefore);
});

// A page of another origin that, once loaded, sends fetches to the edge
// (a no-cors one with a text/plain body, which a browser sends with the
// cookie of a same-site origin, and a CORS one with a JSON body), writes
// their outcome into <body data-results>, then posts a form to the edge
// whose text/plain body is JSON.
function attackerPage(edge: string): string {
  const target = `${edge}/hdrstereo.v1.Sessions/Create`;
  return `<!doctype html><html lang="en"><title>elsewhere</title>
<form id="f" method="post" action="${target}" enctype="text/plain">
<input name='{"name": "evil-form", "note": "' value='"}'></form>
<script>
(async () => {
  const results = [];
  const tries = [
    { method: "POST", mode: "no-cors", credentials: "include",
      headers: { "Content-Type": "text/plain" }, body: JSON.stringify({ name: "evil-no-cors" }) },
    { method: "POST", credentials: "include",
      headers: { "Content-Type": "application/json" }, body: JSON.stringify({ name: "evil-cors" }) },
  ];
  for (const init of tries) {
    try {
      const r = await fetch(${JSON.stringify(target)}, init);
      results.push(r.type + " " + r.status);
    } catch (e) {
      results.push("refused by the browser: " + e.message);
    }
  }
  document.body.dataset.results = JSON.stringify(results);
  document.getElementById("f").submit();
})();
</script></html>`;
}

function serve(server: Server): Promise<string> {
  return new Promise((resolvePromise) => {
    server.listen(0, "127.0.0.1", () => {
      resolvePromise(String((server.address() as AddressInfo).port));
    });
  });
}

test("a form posted from another origin and fetches with a foreign Origin change nothing",
     { timeout: 180_000 }, async () => {
  const sessionsBefore = await sessionsCreated();
  const jobsBefore = await jobsSubmitted();
  const page = attackerPage(daemon.url);
  const handler = (_req: IncomingMessage, res: ServerResponse) => {
    res.writeHead(200, { "Content-Type": "text/html; charset=utf-8" });
    res.end(page);
  };
  const certs = join(daemon.dir, "certs");
  // https on another port of 127.0.0.1: same site as the edge (so the
  // SameSite=Strict cookie goes along), another origin; http: another site.
  const sameSite = createHttpsServer({ cert: readFileSync(join(certs, "server.pem")),
                                       key: readFileSync(join(certs, "server.key")) }, handler);
  const crossSite = createHttpServer(handler);
  const origins = [`https://127.0.0.1:${await serve(sameSite)}`,
                   `http://127.0.0.1:${await serve(crossSite)}`];
  try {
    await withConsole(browser, daemon, "cross-site", async (c) => {
      await signIn(c, operator);
      const cookie = await cookieHeader(c.context, daemon);
      for (const origin of origins) {
        // The attacker's page, in the same browser as the signed-in console
        // (its own problems are the point, not the console's).
        const evil = await c.context.newPage();
        try {
          const edgeAnswers: string[] = [];
          evil.on("response", (r) => {
            if (r.url().startsWith(daemon.url)) {
              edgeAnswers.push(`${r.request().resourceType()} ${r.request().method()} ${r.status()}`);
            }
          });
          const posted = evil.waitForResponse(
            (r) => r.url().startsWith(daemon.url) && r.request().resourceType() === "document",
            { timeout: 30_000 });
          await evil.goto(`${origin}/`);
          const formAnswer = await posted;
          assert.ok(formAnswer.status() >= 400,
                    `the form post from ${origin} was answered ${formAnswer.status()}`);
          // Closing the page before its navigation to the answer commits can
          // leave the browser's next newPage() hanging.
          await evil.waitForURL((u) => u.href.startsWith(daemon.url), { waitUntil: "load" });
          // Every answer the edge gave this page was a refusal (the CORS
          // request may not even have been sent).
          assert.ok(edgeAnswers.every((a) => / (4\d\d)$/.test(a)),
                    `${origin}: ${edgeAnswers.join(", ")}`);
        } finally {
          await evil.close();
        }
      }
      // The console's own cookie with a foreign Origin, as a non-browser
      // client could send it: refused.
      for (const origin of ["https://evil.example", origins[0], "null"]) {
        const forged = await callWithCookie(daemon, "Sessions/Create", { name: "evil-origin" },
                                            cookie, origin);
        assert.equal(forged.status, 403, `${origin}: ${forged.body}`);
        assert.equal(forged.json?.code, "permission_denied");
      }
      // And without any Origin.
      const bare = await callWithCookie(daemon, "Sessions/Create", { name: "evil-no-origin" },
                                        cookie, null);
      assert.equal(bare.status, 403, bare.body);
      // The console itself still works with that cookie and its Origin.
      const who = await callWithCookie(daemon, "Server/WhoAmI", {}, cookie);
      assert.equal(who.json?.principal, "alice");
    });
  } finally {
    await within(10_000, "closing the other origins' servers", Promise.all([
      new Promise((r) => sameSite.close(r)), new Promise((r) => crossSite.close(r)),
    ])).catch(() => undefined);
    sameSite.closeAllConnections();
    crossSite.closeAllConnections();
  }
  assert.deepEqual(await sessionsCreated(), sessionsBefore);
  assert.equal(await jobsSubmitted(), jobsBefore);
});
