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
// last value while a later call fails. When `deps` change the value and
// error of the old ones are dropped at once (never shown under the new),
// unless `extends` says the new deps only extend the old value (a "show
// more" that loads one more page): then it stays until the new one comes.
export function usePoll<T>(load: () => Promise<T>, everyMs: number, deps: unknown[] = [],
                           { extends: extending = false }: { extends?: boolean } = {}): Loaded<T> {
  const [held, setHeld] = useState<{ deps: unknown[]; value?: T; error?: string }>({ deps });
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
        setHeld({ deps, value: v });
      } catch (e) {
        if (live) {
          setHeld((h) => ({ deps, value: extending || sameDeps(h.deps, deps) ? h.value : undefined,
                            error: errorMessage(e) }));
        }
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
  const current = extending || sameDeps(held.deps, deps);
  return {
    value: current ? held.value : undefined,
    error: current ? held.error : undefined,
    reload: () => setTick((t) => t + 1),
  };
}

function sameDeps(a: unknown[], b: unknown[]): boolean {
  return a.length === b.length && a.every((x, i) => Object.is(x, b[i]));
}

// Resolves after `ms`, or at once when `signal` aborts.
export function sleep(ms: number, signal: AbortSignal): Promise<void> {
  return new Promise((resolve) => {
    if (signal.aborted) {
      resolve();
      return;
    }
    const timer = setTimeout(resolve, ms);
    signal.addEventListener("abort", () => { clearTimeout(timer); resolve(); }, { once: true });
  });
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
