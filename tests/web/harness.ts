// SPDX-License-Identifier: GPL-3.0-or-later
//
// What the console's browser tests share: the real hdrstereod on simulated
// hardware with a temporary data root, its gRPC and HTTP edge on free
// loopback ports, the edge over TLS with a test CA made by
// deploy/make-certs.sh; API keys made with the real CLI; Debian's Chromium
// (playwright-core) trusting only that server's key; a watch on each page
// that fails the test on any console error, page error, failed request or
// unexpected HTTP error; axe-core on each page; a screenshot of each page.
//
// Environment (CMake sets it; the defaults fit a build in <repo>/build):
//   HDRSTEREOD, HDRSTEREO_CLI            the daemon and the CLI
//   HDRSTEREO_SOURCE_DIR                 the repository (make-certs.sh, scenes)
//   HDRSTEREO_WEB_SCREENSHOTS            where screenshots go
//   HDRSTEREO_CHROMIUM                   the browser (/usr/bin/chromium)
//   HDRSTEREO_WEB_KEEP=1                 keep the temporary folder
import { type ChildProcess, execFile, spawn } from "node:child_process";
import { createHash, X509Certificate } from "node:crypto";
import { existsSync, mkdirSync, mkdtempSync, openSync, readFileSync, rmSync,
         writeFileSync, closeSync } from "node:fs";
import { request as httpsRequest } from "node:https";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium, type Browser, type BrowserContext, type Page,
         type Request } from "playwright-core";

const here = dirname(fileURLToPath(import.meta.url));
export const kSourceDir = process.env.HDRSTEREO_SOURCE_DIR ?? resolve(here, "../..");
const kBuildDir = resolve(kSourceDir, "build");
export const kDaemon = process.env.HDRSTEREOD ?? join(kBuildDir, "daemon/hdrstereod");
export const kCli = process.env.HDRSTEREO_CLI ?? join(kBuildDir, "clients/cli/hdrstereo");
export const kScreenshots =
  process.env.HDRSTEREO_WEB_SCREENSHOTS ?? join(kBuildDir, "tests/web/screenshots");
const kChromium = process.env.HDRSTEREO_CHROMIUM ?? "/usr/bin/chromium";

export type RoleName = "viewer" | "operator" | "admin";

// The users the daemon knows, by role; the operator is the one the
// walkthrough signs in as.
export const kUsers: Record<RoleName, string> = {
  viewer: "vera",
  operator: "alice",
  admin: "adam",
};

export interface ApiKey {
  user: string;
  role: RoleName;
  key: string;  // hs_<id>_<secret>
  id: string;
}

// Resolves with `promise`, or rejects after `ms` naming `what`.
export async function within<T>(ms: number, what: string, promise: Promise<T>): Promise<T> {
  let timer: ReturnType<typeof setTimeout> | undefined;
  const timeout = new Promise<never>((_, reject) => {
    timer = setTimeout(() => reject(new Error(`${what}: not done within ${ms} ms`)), ms);
  });
  try {
    return await Promise.race([promise, timeout]);
  } finally {
    clearTimeout(timer);
  }
}

export function sleep(ms: number): Promise<void> {
  return new Promise((r) => setTimeout(r, ms));
}

// Polls `probe` every `everyMs` until it returns a value other than
// undefined; rejects after `ms` with `what` and the last error.
export async function until<T>(ms: number, what: string, probe: () => Promise<T | undefined>,
                               everyMs = 100): Promise<T> {
  const deadline = Date.now() + ms;
  let last: unknown;
  for (;;) {
    try {
      const value = await probe();
      if (value !== undefined) return value;
    } catch (e) {
      last = e;
    }
    if (Date.now() > deadline) {
      throw new Error(`${what}: not within ${ms} ms${last ? ` (last: ${String(last)})` : ""}`);
    }
    await sleep(everyMs);
  }
}

interface RunResult {
  code: number;
  out: string;
  err: string;
}

function run(file: string, args: string[], timeoutMs = 60_000,
             env: NodeJS.ProcessEnv = process.env): Promise<RunResult> {
  return new Promise((resolvePromise) => {
    execFile(file, args, { timeout: timeoutMs, env, maxBuffer: 64 << 20 },
             (error, stdout, stderr) => {
               const code = error ? (typeof error.code === "number" ? error.code : -1) : 0;
               resolvePromise({ code, out: stdout, err: stderr });
             });
  });
}

// RFC 7396 JSON merge patch.
export function mergePatch(target: unknown, patch: unknown): unknown {
  if (patch === null || typeof patch !== "object" || Array.isArray(patch)) return patch;
  const out: Record<string, unknown> =
    target && typeof target === "object" && !Array.isArray(target)
      ? { ...(target as Record<string, unknown>) } : {};
  for (const [k, v] of Object.entries(patch as Record<string, unknown>)) {
    if (v === null) delete out[k];
    else out[k] = mergePatch(out[k], v);
  }
  return out;
}

// The bundled lab-lamp at 240 x 180 with a 128 x 96 projector, as the C++
// tests' SmallLabLamp(): captures and processing in seconds.
export const kSmallLabLamp = {
  camera: { width: 240, height: 180, fx: 320, fy: 320, cx: 119.5, cy: 89.5 },
  projector: { width: 128, height: 96 },
};

export interface DaemonOptions {
  // A merge patch of the bundled lab-lamp scene (e.g. kSmallLabLamp).
  scenePatch?: object;
  extraArgs?: string[];
}

export interface HttpAnswer {
  status: number;
  headers: Record<string, string | string[] | undefined>;
  body: string;
  json: any;  // the body parsed, or undefined when it is not JSON
}

// The daemon: started by start(), stopped by stop() (SIGTERM, then SIGKILL
// after 20 s). A watchdog shell kills it should this process die first.
export class Daemon {
  readonly dir: string;
  grpc = "";        // 127.0.0.1:PORT (local, role admin)
  url = "";         // https://127.0.0.1:PORT, the HTTP edge
  ca = "";          // the test CA's certificate (PEM)
  spkiHash = "";    // base64 SHA-256 of the server certificate's SPKI
  private process?: ChildProcess;
  private watchdog?: ChildProcess;
  private exited?: Promise<number | null>;

  private constructor(dir: string) {
    this.dir = dir;
  }

  static async start(options: DaemonOptions = {}): Promise<Daemon> {
    const daemon = new Daemon(mkdtempSync(join(tmpdir(), "hdrstereo-web-")));
    try {
      await daemon.launch(options);
    } catch (e) {
      await daemon.stop(true);
      throw e;
    }
    return daemon;
  }

  private async launch(options: DaemonOptions): Promise<void> {
    if (!existsSync(kDaemon)) throw new Error(`no daemon at ${kDaemon} (build hdrstereod)`);
    const certs = join(this.dir, "certs");
    const makeCerts = join(kSourceDir, "deploy/make-certs.sh");
    for (const args of [[certs, "ca"], [certs, "server", "localhost", "127.0.0.1"]]) {
      const made = await run(makeCerts, args);
      if (made.code !== 0) throw new Error(`make-certs.sh ${args[1]}: ${made.err}`);
    }
    this.ca = readFileSync(join(certs, "ca.pem"), "utf8");
    this.spkiHash = spkiHashOf(readFileSync(join(certs, "server.pem"), "utf8"));

    const ready = join(this.dir, "ready");
    const args = [
      "--data-root", join(this.dir, "data"), "--hardware", "sim",
      "--listen", "127.0.0.1:0", "--http-listen", "127.0.0.1:0",
      "--tls-cert", join(certs, "server.pem"), "--tls-key", join(certs, "server.key"),
      "--tls-client-ca", join(certs, "ca.pem"), "--ready-file", ready,
    ];
    for (const [role, user] of Object.entries(kUsers)) args.push("--auth-user", `${user}=${role}`);
    if (options.scenePatch) {
      const bundled = JSON.parse(
        readFileSync(join(kSourceDir, "hardware/sim/scenes/lab-lamp.json"), "utf8"));
      const scene = join(this.dir, "scene.json");
      writeFileSync(scene, JSON.stringify(mergePatch(bundled, options.scenePatch), null, 2));
      args.push("--sim-scene", scene);
    }
    args.push(...(options.extraArgs ?? []));

    const log = openSync(join(this.dir, "daemon.log"), "w");
    const child = spawn(kDaemon, args, { stdio: ["ignore", log, log] });
    closeSync(log);
    this.process = child;
    this.exited = new Promise((r) => child.on("exit", (code) => r(code)));
    this.watchdog = spawn("bash", ["-c",
      `while kill -0 ${process.pid} 2>/dev/null; do sleep 1; done; kill -KILL ${child.pid} 2>/dev/null`],
      { detached: true, stdio: "ignore" });
    this.watchdog.unref();

    let gone = false;
    void this.exited.then(() => { gone = true; });
    const lines = await until(60_000, "hdrstereod's ready file", async () => {
      if (gone) throw new Error(`hdrstereod exited at start:\n${this.logTail()}`);
      if (!existsSync(ready)) return undefined;
      const text = readFileSync(ready, "utf8");
      return text.endsWith("\n") ? text.trim().split("\n") : undefined;
    }, 50).catch((e) => { throw new Error(`${e.message}\n${this.logTail()}`); });
    this.grpc = lines.find((l) => !l.startsWith("http")) ?? "";
    this.url = lines.find((l) => l.startsWith("https://")) ?? "";
    if (!this.grpc || !this.url) throw new Error(`ready file without both addresses: ${lines}`);
  }

  logTail(lines = 40): string {
    try {
      return readFileSync(join(this.dir, "daemon.log"), "utf8").split("\n").slice(-lines).join("\n");
    } catch {
      return "(no daemon log)";
    }
  }

  // The CLI as the local admin over the loopback gRPC port.
  cli(args: string[], timeoutMs = 60_000): Promise<RunResult> {
    return run(kCli, ["--server", this.grpc, ...args], timeoutMs);
  }

  async createKey(role: RoleName, user = kUsers[role], note = "browser test"): Promise<ApiKey> {
    const made = await this.cli(["admin", "key", "create", "--user", user, "--role", role,
                                 "--expires", "1d", "--note", note]);
    const key = made.out.trim();
    const id = /^hs_([0-9a-f]+)_/.exec(key)?.[1];
    if (made.code !== 0 || !id) throw new Error(`admin key create: ${made.code} ${made.err}`);
    return { user, role, key, id };
  }

  async revokeKey(key: ApiKey): Promise<void> {
    const revoked = await this.cli(["admin", "key", "revoke", key.id]);
    if (revoked.code !== 0) throw new Error(`admin key revoke: ${revoked.code} ${revoked.err}`);
  }

  // One request to the edge, trusting only the test CA.
  fetch(path: string, init: { method?: string; headers?: Record<string, string>;
                              body?: string | Buffer; timeoutMs?: number } = {}):
      Promise<HttpAnswer & { raw: Buffer }> {
    const url = new URL(path, this.url);
    return within(init.timeoutMs ?? 60_000, `${init.method ?? "GET"} ${path}`,
                  new Promise((resolvePromise, reject) => {
      const req = httpsRequest(url, {
        method: init.method ?? "GET",
        headers: init.headers,
        ca: this.ca,
      }, (res) => {
        const chunks: Buffer[] = [];
        res.on("data", (c: Buffer) => chunks.push(c));
        res.on("end", () => {
          const raw = Buffer.concat(chunks);
          const body = raw.toString("utf8");
          let json: unknown;
          try {
            json = JSON.parse(body);
          } catch {
            json = undefined;
          }
          resolvePromise({ status: res.statusCode ?? 0, headers: res.headers, body, json, raw });
        });
        res.on("error", reject);
      });
      req.on("error", reject);
      if (init.body !== undefined) req.write(init.body);
      req.end();
    }));
  }

  // A unary call as JSON with `key` as Bearer (Service/Method).
  call(method: string, body: object, key: ApiKey | string): Promise<HttpAnswer> {
    const secret = typeof key === "string" ? key : key.key;
    return this.fetch(`/hdrstereo.v1.${method}`, {
      method: "POST",
      headers: { "Content-Type": "application/json", Authorization: `Bearer ${secret}` },
      body: JSON.stringify(body),
    });
  }

  // The same, failing on anything but 200; the answer's JSON.
  async ok(method: string, body: object, key: ApiKey | string): Promise<any> {
    const answer = await this.call(method, body, key);
    if (answer.status !== 200) throw new Error(`${method}: HTTP ${answer.status} ${answer.body}`);
    return answer.json;
  }

  // A server stream (e.g. Jobs/Watch) to its end as Server-Sent Events: its
  // messages, in order; throws on an error event.
  async stream(method: string, body: object, key: ApiKey, timeoutMs = 120_000): Promise<any[]> {
    const answer = await this.fetch(`/hdrstereo.v1.${method}`, {
      method: "POST",
      headers: { "Content-Type": "application/json", Accept: "text/event-stream",
                 Authorization: `Bearer ${key.key}` },
      body: JSON.stringify(body),
      timeoutMs,
    });
    if (answer.status !== 200) throw new Error(`${method}: HTTP ${answer.status} ${answer.body}`);
    const messages: any[] = [];
    for (const block of answer.body.split("\n\n")) {
      const data = block.split("\n").filter((l) => l.startsWith("data: "))
        .map((l) => l.slice(6)).join("\n");
      if (!data) continue;
      if (/^event: end$/m.test(block)) {
        const end = JSON.parse(data);
        if (end.error) throw new Error(`${method}: ${JSON.stringify(end.error)}`);
        break;
      }
      messages.push(JSON.parse(data));
    }
    return messages;
  }

  async stop(keepDir = process.env.HDRSTEREO_WEB_KEEP === "1"): Promise<number | null> {
    let code: number | null = null;
    const child = this.process;
    if (child && child.exitCode === null && child.signalCode === null) {
      child.kill("SIGTERM");
      const stopped = await Promise.race([this.exited!, sleep(20_000).then(() => "timeout")]);
      if (stopped === "timeout") {
        child.kill("SIGKILL");
        await this.exited;
      } else {
        code = stopped as number | null;
      }
    }
    if (this.watchdog?.pid && this.watchdog.exitCode === null) {
      try {
        process.kill(this.watchdog.pid, "SIGKILL");
      } catch {
        // already gone
      }
    }
    if (!keepDir) rmSync(this.dir, { recursive: true, force: true });
    return code;
  }
}

// base64 SHA-256 of a certificate's SubjectPublicKeyInfo, as Chromium's
// --ignore-certificate-errors-spki-list takes it.
export function spkiHashOf(pem: string): string {
  const spki = new X509Certificate(pem).publicKey.export({ type: "spki", format: "der" });
  return createHash("sha256").update(spki).digest("base64");
}

// Debian's Chromium, headless, trusting the server key `spkiHash` and
// nothing else beyond the system's roots.
export async function launchBrowser(spkiHash: string, extraArgs: string[] = []):
    Promise<Browser> {
  return within(60_000, "Chromium's start", chromium.launch({
    executablePath: kChromium,
    headless: true,
    args: [`--ignore-certificate-errors-spki-list=${spkiHash}`, ...extraArgs],
    timeout: 60_000,
  }));
}

interface Allowance {
  url: RegExp;
  status: number;  // an HTTP status, or 0 for a failed request
  error?: RegExp;  // for a failed request: its error text
}

// Every console error, page error, failed request and HTTP error answer of
// a page; the test allows what it expects (allow()) and asserts none other
// came (assertClean()).
export class PageWatch {
  private readonly problems: string[] = [];
  private readonly allowances: Allowance[] = [];
  private stopped = false;
  private readonly answered = new WeakSet<Request>();

  constructor(readonly page: Page, readonly name: string) {
    page.on("console", (message) => {
      if (this.stopped || message.type() !== "error") return;
      const url = message.location().url;
      // Chromium logs each HTTP error answer as "Failed to load resource:
      // the server responded with a status of 401 ()".
      const status = /responded with a status of (\d+)/.exec(message.text())?.[1];
      if (status && this.allowed(url, Number(status))) return;
      // ... and each failed request as "Failed to load resource: net::...".
      const failure = /Failed to load resource: (net::[A-Z_]+)/.exec(message.text())?.[1];
      if (failure && this.allowed(url, 0, failure)) return;
      this.problems.push(`console error: ${message.text()} (at ${url || "?"})`);
    });
    page.on("pageerror", (error) => {
      if (!this.stopped) this.problems.push(`page error: ${error.message}`);
    });
    page.on("requestfailed", (request) => {
      if (this.stopped) return;
      const failure = request.failure()?.errorText ?? "?";
      // Aborted after its answer came: a body the page did not read (e.g.
      // sign-in's) cut off by a navigation, or a stream the page ended
      // itself (leaving live view, a job's watch).
      const answered = failure === "net::ERR_ABORTED" && this.answered.has(request);
      if (answered || this.allowed(request.url(), 0, failure)) return;
      this.problems.push(`request failed: ${request.method()} ${request.url()}: ${failure}`);
    });
    page.on("response", (response) => {
      this.answered.add(response.request());
      if (this.stopped || response.status() < 400) return;
      if (this.allowed(response.url(), response.status())) return;
      this.problems.push(`HTTP ${response.status()}: ${response.request().method()} ${response.url()}`);
    });
  }

  // Expects answers with `status` (0: failed requests whose error matches
  // `error`) for URLs matching `url` from now on.
  allow(url: RegExp | string, status: number, error?: RegExp): void {
    const pattern = typeof url === "string"
      ? new RegExp(url.replace(/[.*+?^${}()|[\]\\]/g, "\\$&")) : url;
    this.allowances.push({ url: pattern, status, error });
  }

  // Forgets every allowance.
  disallowAll(): void {
    this.allowances.length = 0;
  }

  private allowed(url: string, status: number, error?: string): boolean {
    return this.allowances.some((a) => a.url.test(url) && a.status === status &&
                                       (status !== 0 || !a.error || a.error.test(error ?? "")));
  }

  list(): string[] {
    return [...this.problems];
  }

  assertClean(): void {
    if (this.problems.length > 0) {
      throw new Error(`page ${this.name}: ${this.problems.length} problem(s):\n  ` +
                      this.problems.join("\n  "));
    }
  }

  stop(): void {
    this.stopped = true;
  }
}

const require = createRequire(import.meta.url);
const kAxeSource = readFileSync(require.resolve("axe-core/axe.min.js"), "utf8");

export interface AxeViolation {
  id: string;
  impact: string;
  help: string;
  nodes: string[];
}

// Runs axe-core on the page as it is; throws listing every serious or
// critical violation. The page's CSP allows no inline script, so axe is
// evaluated through the DevTools protocol (which CSP does not govern), not
// added as a <script>.
export async function checkAccessibility(page: Page, name: string): Promise<AxeViolation[]> {
  const loaded = await page.evaluate("typeof window.axe !== 'undefined'");
  if (!loaded) await page.evaluate(kAxeSource);
  const violations = await page.evaluate(async () => {
    const axe = (window as any).axe;
    const result = await axe.run(document, { resultTypes: ["violations"] });
    return result.violations.map((v: any) => ({
      id: v.id, impact: v.impact ?? "", help: v.help,
      nodes: v.nodes.slice(0, 5).map((n: any) => `${n.target.join(" ")}: ${n.failureSummary ?? ""}`),
    }));
  }) as AxeViolation[];
  const serious = violations.filter((v) => v.impact === "serious" || v.impact === "critical");
  if (serious.length > 0) {
    throw new Error(`axe-core on ${name}: ${serious.length} serious or critical violation(s):\n` +
      serious.map((v) => `  ${v.impact} ${v.id}: ${v.help}\n    ${v.nodes.join("\n    ")}`)
        .join("\n"));
  }
  return violations;
}

// Writes the page as it is to <screenshots>/<name>.png.
export async function screenshot(page: Page, name: string): Promise<string> {
  mkdirSync(kScreenshots, { recursive: true });
  const path = join(kScreenshots, `${name}.png`);
  await page.screenshot({ path, fullPage: true, timeout: 30_000 });
  return path;
}

// Looks at a page that has landed: its screenshot, then axe-core.
export async function inspect(page: Page, name: string): Promise<void> {
  await screenshot(page, name);
  await checkAccessibility(page, name);
}

export interface Console {
  context: BrowserContext;
  page: Page;
  watch: PageWatch;
}

// A fresh browser context (its own cookies) at 1280 x 800 with one page on
// the console, watched.
export async function openConsole(browser: Browser, daemon: Daemon, name: string,
                                  viewport = { width: 1280, height: 800 }): Promise<Console> {
  const context = await browser.newContext({ baseURL: daemon.url, viewport, locale: "en-GB" });
  context.setDefaultTimeout(15_000);
  const page = await context.newPage();
  const watch = new PageWatch(page, name);
  return { context, page, watch };
}

// Loads the console signed out (it asks /auth/session first, so no call
// is refused).
export async function loadSignedOut(c: Console): Promise<void> {
  await c.page.goto("/", { waitUntil: "load" });
  await c.page.getByLabel("API key").waitFor();
}

// Signs in through the form; resolves once the header names the user.
export async function signIn(c: Console, key: ApiKey): Promise<void> {
  await loadSignedOut(c);
  await c.page.getByLabel("API key").fill(key.key);
  await c.page.getByRole("button", { name: "Sign in" }).click();
  await c.page.getByTestId("who").waitFor();
}

// Stops the daemon; throws unless it exited cleanly (0) on SIGTERM, so a
// crash during a test fails it.
export async function stopCleanly(daemon: Daemon | undefined): Promise<void> {
  if (!daemon) return;
  const code = await daemon.stop();
  if (code !== 0) {
    throw new Error(`hdrstereod exited with ${code} on SIGTERM:\n${daemon.logTail()}`);
  }
}

// Closes everything a test opened, in order, whatever failed; rethrows the
// first error.
export async function closeAll(steps: (() => Promise<unknown> | unknown)[]): Promise<void> {
  let first: unknown;
  for (const step of steps) {
    try {
      await within(30_000, "closing", Promise.resolve().then(step));
    } catch (e) {
      first ??= e;
    }
  }
  if (first) throw first;
}

// Runs `body` on a fresh console page named `name`; then the page must have
// had no unexpected problem. On failure the error carries the page's
// problems and the daemon's log, and a screenshot <name>-failure.png is
// written. The page's context is closed either way.
export async function withConsole<T>(browser: Browser, daemon: Daemon, name: string,
                                     body: (c: Console) => Promise<T>,
                                     viewport?: { width: number; height: number }): Promise<T> {
  const c = await openConsole(browser, daemon, name, viewport);
  try {
    const result = await body(c);
    c.watch.assertClean();
    return result;
  } catch (e) {
    await screenshot(c.page, `${name}-failure`).catch(() => undefined);
    if (e instanceof Error) {
      e.message += `\n--- problems on the page:\n  ${c.watch.list().join("\n  ") || "(none)"}` +
                   `\n--- the daemon's log (last lines):\n${daemon.logTail(30)}`;
    }
    throw e;
  } finally {
    c.watch.stop();
    await within(30_000, "closing the page", c.context.close()).catch(() => undefined);
  }
}

// The Cookie header a signed-in context sends to the edge.
export async function cookieHeader(context: BrowserContext, daemon: Daemon): Promise<string> {
  return (await context.cookies(daemon.url)).map((c) => `${c.name}=${c.value}`).join("; ");
}

// A unary call as a browser signed in with `cookie` would make it (its
// Origin by default).
export function callWithCookie(daemon: Daemon, method: string, body: object, cookie: string,
                               origin: string | null = daemon.url): Promise<HttpAnswer> {
  const headers: Record<string, string> = { "Content-Type": "application/json", Cookie: cookie };
  if (origin !== null) headers.Origin = origin;
  return daemon.fetch(`/hdrstereo.v1.${method}`, {
    method: "POST", headers, body: JSON.stringify(body),
  });
}
