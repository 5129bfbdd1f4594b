// SPDX-License-Identifier: GPL-3.0-or-later
//
// Small pieces every page uses: a polled or streamed value with its error,
// an error box, a status badge that says its state in words (never by
// colour alone), byte and duration formatting.
import type { ComponentChildren } from "preact";
import { useEffect, useRef, useState } from "preact/hooks";
import { errorMessage } from "./api";

export interface Loaded<T> {
  value?: T;
  error?: string;
  reload: () => void;
}

// Calls `load` now, every `everyMs` (0: once) and on reload(); keeps the
// last value while a later call fails.
export function usePoll<T>(load: () => Promise<T>, everyMs: number,
                           deps: unknown[] = []): Loaded<T> {
  const [value, setValue] = useState<T | undefined>(undefined);
  const [error, setError] = useState<string | undefined>(undefined);
  const [tick, setTick] = useState(0);
  const loadRef = useRef(load);
  loadRef.current = load;
  useEffect(() => {
    let live = true;
    let timer: ReturnType<typeof setTimeout> | undefined;
    const run = async () => {
      try {
        const v = await loadRef.current();
        if (!live) return;
        setValue(v);
        setError(undefined);
      } catch (e) {
        if (live) setError(errorMessage(e));
      }
      if (live && everyMs > 0) timer = setTimeout(run, everyMs);
    };
    run();
    return () => {
      live = false;
      if (timer) clearTimeout(timer);
    };
    // eslint-disable-next-line react-hooks/exhaustive-deps
  }, [tick, everyMs, ...deps]);
  return { value, error, reload: () => setTick((t) => t + 1) };
}

export function ErrorBox({ error }: { error?: string }) {
  if (!error) return null;
  return <p class="error" role="alert"><strong>Error:</strong> {error}</p>;
}

// A state in words with a symbol; the colour only repeats it.
export function Badge({ tone, children }:
                      { tone: "ok" | "warn" | "bad" | "idle"; children: ComponentChildren }) {
  const symbol = { ok: "●", warn: "▲", bad: "✖", idle: "○" }[tone];
  return <span class={`badge ${tone}`}><span aria-hidden="true">{symbol} </span>{children}</span>;
}

export function Section({ title, children }: { title: string; children: ComponentChildren }) {
  return <section class="card" aria-label={title}><h2>{title}</h2>{children}</section>;
}

export function formatBytes(bytes: number | bigint): string {
  let n = Number(bytes);
  const units = ["B", "KiB", "MiB", "GiB", "TiB"];
  let i = 0;
  while (Math.abs(n) >= 1024 && i < units.length - 1) {
    n /= 1024;
    ++i;
  }
  return `${n.toFixed(i === 0 ? 0 : 1)} ${units[i]}`;
}

export function formatDuration(seconds: number): string {
  if (!Number.isFinite(seconds) || seconds < 0) return "–";
  const s = Math.round(seconds);
  if (s < 60) return `${s} s`;
  const m = Math.floor(s / 60);
  if (m < 60) return `${m} min ${s % 60} s`;
  return `${Math.floor(m / 60)} h ${m % 60} min`;
}

export function formatTime(t?: { seconds: bigint; nanos: number }): string {
  if (!t) return "–";
  return new Date(Number(t.seconds) * 1000 + t.nanos / 1e6).toLocaleString();
}
