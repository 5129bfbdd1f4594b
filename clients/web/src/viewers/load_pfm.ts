// SPDX-License-Identifier: GPL-3.0-or-later
//
// Fetches a PFM artifact from the edge (with the session cookie) and parses
// it, as a hook the viewers share: the map, or where it failed.
import { useEffect, useState } from "preact/hooks";
import { parsePfm, type Pfm } from "../pfm";

export interface PfmLoad {
  pfm?: Pfm;
  error?: string;
  bytes?: number;
}

export async function fetchPfm(url: string, signal?: AbortSignal): Promise<{ pfm: Pfm; bytes: number }> {
  const response = await fetch(url, { credentials: "same-origin", signal });
  if (!response.ok) {
    let message = `HTTP ${response.status}`;
    try {
      const body = await response.json();
      if (typeof body?.message === "string") message = body.message;
    } catch {
      // not JSON: keep the status
    }
    throw new Error(`${url}: ${message}`);
  }
  const buffer = await response.arrayBuffer();
  return { pfm: parsePfm(buffer), bytes: buffer.byteLength };
}

// Loads `url` (nothing when undefined); a new url replaces the old map.
export function usePfm(url: string | undefined): PfmLoad {
  const [state, setState] = useState<PfmLoad>({});
  useEffect(() => {
    setState({});
    if (!url) return;
    const abort = new AbortController();
    fetchPfm(url, abort.signal).then(
      ({ pfm, bytes }) => setState({ pfm, bytes }),
      (e) => {
        if (!abort.signal.aborted) setState({ error: e instanceof Error ? e.message : String(e) });
      });
    return () => abort.abort();
  }, [url]);
  return state;
}
