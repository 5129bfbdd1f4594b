// SPDX-License-Identifier: GPL-3.0-or-later
//
// The daemon's API for the console: one Connect transport to the HTTP edge
// this page came from (binary protobuf, so live-view JPEGs travel as bytes),
// a client per service, sign-in and sign-out, and errors as the server
// worded them. The session is the edge's HttpOnly cookie: nothing secret is
// kept in the page.
import { Code, ConnectError, createClient, type Interceptor } from "@connectrpc/connect";
import { createConnectTransport } from "@connectrpc/connect-web";
import { Admin } from "../gen/hdrstereo/v1/admin_pb";
import { Hardware } from "../gen/hdrstereo/v1/hardware_pb";
import { Jobs } from "../gen/hdrstereo/v1/jobs_pb";
import { Schedules } from "../gen/hdrstereo/v1/schedules_pb";
import { Server } from "../gen/hdrstereo/v1/server_pb";
import { Sessions } from "../gen/hdrstereo/v1/sessions_pb";

// Fired on window when a call finds the session gone (signed out elsewhere,
// key revoked or expired, daemon restarted): the app shows the sign-in.
export const kSignedOutEvent = "hdrstereo:signed-out";

const signedOutWatch: Interceptor = (next) => async (req) => {
  try {
    return await next(req);
  } catch (e) {
    if (ConnectError.from(e).code === Code.Unauthenticated) {
      window.dispatchEvent(new Event(kSignedOutEvent));
    }
    throw e;
  }
};

const transport = createConnectTransport({
  baseUrl: window.location.origin,
  useBinaryFormat: true,
  interceptors: [signedOutWatch],
  fetch: (input, init) => fetch(input, { ...init, credentials: "same-origin" }),
});

export const api = {
  server: createClient(Server, transport),
  hardware: createClient(Hardware, transport),
  jobs: createClient(Jobs, transport),
  sessions: createClient(Sessions, transport),
  schedules: createClient(Schedules, transport),
  admin: createClient(Admin, transport),
};

// The server's own words for a failed call (its message names, e.g., the
// role a call needs); anything else as its message.
export function errorMessage(e: unknown): string {
  if (e instanceof ConnectError) return e.rawMessage || Code[e.code];
  return e instanceof Error ? e.message : String(e);
}

export function errorCode(e: unknown): Code | undefined {
  return e instanceof ConnectError ? e.code : undefined;
}

async function postJson(path: string, body: unknown): Promise<Response> {
  return fetch(path, {
    method: "POST",
    credentials: "same-origin",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify(body),
  });
}

// Signs in with an API key; the key goes only into this request's body.
// Throws with the server's message when refused.
export async function signIn(apiKey: string): Promise<void> {
  const response = await postJson("/auth/sign-in", { apiKey });
  if (response.ok) return;
  let message = `sign-in failed (HTTP ${response.status})`;
  try {
    const body = await response.json();
    if (typeof body?.message === "string") message = body.message;
  } catch {
    // not JSON: keep the status
  }
  throw new Error(message);
}

// Whether the page's session cookie (or client certificate) is good, asked
// before the first call so that being signed out is an answer, not a 401.
export async function isSignedIn(): Promise<boolean> {
  const response = await fetch("/auth/session", { credentials: "same-origin" });
  if (!response.ok) throw new Error(`session check failed (HTTP ${response.status})`);
  const body = await response.json();
  return body?.signedIn === true;
}

export async function signOut(): Promise<void> {
  await postJson("/auth/sign-out", {});
}

// The URL of a session's file on the edge (GET with Range and ETag).
export function fileUrl(session: string, kind: "frames" | "artifacts",
                        id: bigint | number | string): string {
  return `/files/sessions/${encodeURIComponent(session)}/${kind}/${id}`;
}

// A session's HTML report as a page (the edge serves its images beside it
// on the same route, so the page's relative links resolve).
export function reportUrl(session: string): string {
  return `/files/sessions/${encodeURIComponent(session)}/report/index.html`;
}
