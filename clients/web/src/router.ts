// SPDX-License-Identifier: GPL-3.0-or-later
//
// Hash routes (#/live, #/sessions/NAME, #/jobs/42): the daemon serves one
// page, and a route survives a reload or a link sent to a colleague.
import { useEffect, useState } from "preact/hooks";

export interface Route {
  page: string;      // "rig", "live", "capture", "jobs", "sessions", ...
  params: string[];  // the rest of the path, decoded
}

export function parseRoute(hash: string): Route {
  const parts = hash.replace(/^#\/?/, "").split("/").filter((p) => p !== "");
  const [page = "rig", ...rest] = parts;
  return { page, params: rest.map(decodePart) };
}

// A malformed escape (#/sessions/%E0) is kept as typed rather than thrown.
function decodePart(part: string): string {
  try {
    return decodeURIComponent(part);
  } catch {
    return part;
  }
}

export function href(page: string, ...params: (string | number | bigint)[]): string {
  return `#/${[page, ...params.map((p) => encodeURIComponent(String(p)))].join("/")}`;
}

export function useRoute(): Route {
  const [route, setRoute] = useState(() => parseRoute(window.location.hash));
  useEffect(() => {
    const onChange = () => setRoute(parseRoute(window.location.hash));
    window.addEventListener("hashchange", onChange);
    return () => window.removeEventListener("hashchange", onChange);
  }, []);
  return route;
}
