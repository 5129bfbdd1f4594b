// SPDX-License-Identifier: GPL-3.0-or-later
//
// Signing in to the console in Chromium over TLS: with a key, with a wrong
// or revoked one, a key revoked under an open page, signing out; where the
// session lives (an HttpOnly, Secure, __Host- cookie) and where the key
// never is (storage, script-readable cookies, the URL, the page).
import assert from "node:assert/strict";
import { after, before, test } from "node:test";
import type { Browser } from "playwright-core";
import { type ApiKey, callWithCookie, closeAll, cookieHeader, Daemon, inspect, launchBrowser,
         loadSignedOut, signIn, stopCleanly, withConsole } from "./harness.ts";

let daemon: Daemon;
let browser: Browser;
let operator: ApiKey;

before(async () => {
  daemon = await Daemon.start();
  browser = await launchBrowser(daemon.spkiHash);
  operator = await daemon.createKey("operator");
}, { timeout: 120_000 });

after(async () => {
  await closeAll([() => browser?.close(), () => stopCleanly(daemon)]);
}, { timeout: 60_000 });

const kSignInError = "#sign-in-error";

// What the edge answers a sign-in with `key` (from Node, not the page).
async function refusal(key: string): Promise<{ status: number; message: string }> {
  const answer = await daemon.fetch("/auth/sign-in", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ apiKey: key }),
  });
  return { status: answer.status, message: answer.json?.message ?? "" };
}

test("the operator signs in with a key: the header names alice (operator); the session is an " +
     "HttpOnly Secure __Host- cookie and the key is kept nowhere", { timeout: 120_000 }, async () => {
  await withConsole(browser, daemon, "sign-in", async (c) => {
    const urls: string[] = [];
    c.page.on("request", (r) => urls.push(r.url()));
    await loadSignedOut(c);
    await inspect(c.page, "sign-in");

    await c.page.getByLabel("API key").fill(operator.key);
    await c.page.getByRole("button", { name: "Sign in" }).click();
    await c.page.getByTestId("who").waitFor();
    assert.equal(await c.page.getByTestId("who").textContent(), "alice (operator)");
    // The Rig page, the first one, has landed with the daemon's data.
    await c.page.getByRole("heading", { name: "Rig", level: 1 }).waitFor();
    await c.page.getByText("hdrstereo simulated camera").first().waitFor();
    await inspect(c.page, "rig");

    const cookies = await c.context.cookies();
    assert.equal(cookies.length, 1, JSON.stringify(cookies));
    const [cookie] = cookies;
    assert.equal(cookie.name, "__Host-hdrstereo_session");
    assert.equal(cookie.httpOnly, true);
    assert.equal(cookie.secure, true);
    assert.equal(cookie.sameSite, "Strict");
    assert.equal(cookie.path, "/");
    assert.equal(cookie.domain, "127.0.0.1");  // host-only: no Domain attribute
    assert.notEqual(cookie.value, operator.key);

    // (No named inner functions: tsx would wrap them in a helper the page
    // does not have.)
    const seen = await c.page.evaluate(() => {
      const [local, session] = [localStorage, sessionStorage].map((s) =>
        Array.from({ length: s.length }, (_, i) => `${s.key(i)}=${s.getItem(s.key(i)!)}`)
          .join("\n"));
      const inputs = Array.from(document.querySelectorAll("input, textarea"))
        .map((e) => (e as HTMLInputElement).value).join("\n");
      return { local, session, cookie: document.cookie, url: location.href,
               history: String(history.state), html: document.documentElement.outerHTML, inputs };
    });
    assert.equal(seen.local, "");
    assert.equal(seen.session, "");
    assert.equal(seen.cookie, "", "the session cookie must be invisible to scripts");
    const secret = operator.key.split("_")[2];
    for (const [where, text] of Object.entries(seen)) {
      assert.ok(!text.includes(secret), `the key's secret is in ${where}`);
    }
    assert.ok(!c.page.url().includes(secret));
    assert.ok(urls.every((u) => !u.includes(secret)), "the key was in a request's URL");

    // The cookie is what a browser call carries: the edge knows alice by it.
    const who = await callWithCookie(daemon, "Server/WhoAmI", {},
                                     await cookieHeader(c.context, daemon));
    assert.equal(who.status, 200, who.body);
    assert.equal(who.json.principal, "alice");
    assert.equal(who.json.role, "ROLE_OPERATOR");
  });
});

test("a wrong key is refused with the server's message and the page stays signed out",
     { timeout: 120_000 }, async () => {
  await withConsole(browser, daemon, "sign-in-wrong-key", async (c) => {
    await loadSignedOut(c);
    c.watch.allow(/\/auth\/sign-in$/, 401);
    // Well formed, with the operator's key id and another secret; and an
    // id the daemon never made.
    const wrong = [operator.key.replace(/_[0-9a-f]+$/, `_${"0".repeat(64)}`),
                   `hs_0123456789ab_${"1".repeat(64)}`];
    for (const key of wrong) {
      await c.page.getByLabel("API key").fill(key);
      await c.page.getByRole("button", { name: "Sign in" }).click();
      const shown = c.page.locator(kSignInError);
      await shown.waitFor();
      const expected = await refusal(key);
      assert.equal(expected.status, 401);
      assert.ok(expected.message.length > 0);
      assert.equal(await shown.textContent(), expected.message);
      assert.equal(await c.page.getByTestId("who").count(), 0);
      assert.deepEqual(await c.context.cookies(), []);
    }
    await inspect(c.page, "sign-in-refused");
  });
});

test("a revoked key is refused", { timeout: 120_000 }, async () => {
  const revoked = await daemon.createKey("operator", undefined, "revoked before use");
  await daemon.revokeKey(revoked);
  await withConsole(browser, daemon, "sign-in-revoked-key", async (c) => {
    await loadSignedOut(c);
    c.watch.allow(/\/auth\/sign-in$/, 401);
    await c.page.getByLabel("API key").fill(revoked.key);
    await c.page.getByRole("button", { name: "Sign in" }).click();
    const shown = c.page.locator(kSignInError);
    await shown.waitFor();
    const expected = await refusal(revoked.key);
    assert.equal(expected.status, 401);
    assert.match(expected.message, /revoked/);
    assert.equal(await shown.textContent(), expected.message);
    assert.equal(await c.page.getByTestId("who").count(), 0);
    assert.deepEqual(await c.context.cookies(), []);
  });
});

test("revoking the key of a signed-in page signs it out: its next call shows the sign-in " +
     "with a notice", { timeout: 120_000 }, async () => {
  const key = await daemon.createKey("operator", undefined, "revoked while in use");
  await withConsole(browser, daemon, "signed-out-by-revocation", async (c) => {
    await signIn(c, key);
    await c.page.getByRole("heading", { name: "Rig", level: 1 }).waitFor();
    const cookie = await cookieHeader(c.context, daemon);
    // From here on the page's calls are refused until it shows the sign-in.
    c.watch.allow(/\/hdrstereo\.v1\.[A-Za-z]+\/[A-Za-z]+$/, 401);
    await daemon.revokeKey(key);
    // The Rig page polls; its next call finds the session gone.
    const notice = c.page.getByRole("status").filter({ hasText: "Your session ended" });
    await notice.waitFor({ timeout: 20_000 });
    await c.page.getByLabel("API key").waitFor();
    assert.equal(await c.page.getByTestId("who").count(), 0);
    await inspect(c.page, "signed-out-notice");
    const after = await callWithCookie(daemon, "Server/WhoAmI", {}, cookie);
    assert.equal(after.status, 401, after.body);
  });
});

test("signing out ends the session: its cookie no longer works", { timeout: 120_000 },
     async () => {
  await withConsole(browser, daemon, "sign-out", async (c) => {
    await signIn(c, operator);
    const cookie = await cookieHeader(c.context, daemon);
    assert.equal((await callWithCookie(daemon, "Server/WhoAmI", {}, cookie)).status, 200);
    await c.page.getByRole("button", { name: "Sign out" }).click();
    await c.page.getByLabel("API key").waitFor();
    assert.equal(await c.page.getByTestId("who").count(), 0);
    const after = await callWithCookie(daemon, "Server/WhoAmI", {}, cookie);
    assert.equal(after.status, 401, after.body);
    // A reload stays signed out.
    await c.page.reload();
    await c.page.getByLabel("API key").waitFor();
    assert.equal(await c.page.getByTestId("who").count(), 0);
  });
});
