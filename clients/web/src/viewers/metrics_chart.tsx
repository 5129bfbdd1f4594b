// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thesis-style comparison of methods (Table 5.2 as bars): per ground
// truth, the RMSE and the bad-pixel rate of each method as horizontal SVG
// bars, each with its value written at its end, so nothing rests on colour
// or on reading a bar's length against the axis.
import { useState } from "preact/hooks";
import type { Metric } from "../../gen/hdrstereo/v1/sessions_pb";
import { barScale, formatPercent, formatPx } from "../results";

type BadKey = "bad_0_5" | "bad_1" | "bad_2" | "bad_4";
const kBadThresholds: { key: BadKey; field: keyof Metric; label: string }[] = [
  { key: "bad_0_5", field: "bad05", label: "0.5 px" },
  { key: "bad_1", field: "bad1", label: "1 px" },
  { key: "bad_2", field: "bad2", label: "2 px" },
  { key: "bad_4", field: "bad4", label: "4 px" },
];

const kRow = 22;        // px per bar
const kLabelWidth = 130;
const kBarWidth = 300;
const kValueWidth = 70;
const kTop = 8;
const kAxis = 36;

interface BarsProps {
  id: string;
  title: string;
  unit: string;
  rows: { method: string; value: number }[];
  format: (v: number) => string;
}

function Bars({ id, title, unit, rows, format }: BarsProps) {
  const scale = barScale(rows.map((r) => r.value));
  const width = kLabelWidth + kBarWidth + kValueWidth;
  const height = kTop + rows.length * kRow + kAxis;
  const x = (v: number) => kLabelWidth + (Math.max(0, v) / scale.max) * kBarWidth;
  return (
    <svg class="metrics-bars" viewBox={`0 0 ${width} ${height}`} width={width} height={height}
         role="img" aria-labelledby={`${id}-title`} data-chart={id}>
      <title id={`${id}-title`}>
        {title}: {rows.map((r) => `${r.method} ${format(r.value)}`).join(", ")}
      </title>
      {scale.ticks.map((t) => (
        <g key={t} class="tick">
          <line x1={x(t)} x2={x(t)} y1={kTop - 4} y2={kTop + rows.length * kRow} />
          <text x={x(t)} y={kTop + rows.length * kRow + 16} text-anchor="middle">{t}</text>
        </g>
      ))}
      <text class="unit" x={kLabelWidth + kBarWidth} y={height - 1} text-anchor="end">{unit}</text>
      {rows.map((r, i) => {
        const y = kTop + i * kRow;
        return (
          <g key={r.method} data-method={r.method} data-value={String(r.value)}>
            <text x={kLabelWidth - 6} y={y + kRow / 2 + 4} text-anchor="end">{r.method}</text>
            <rect class="bar" x={kLabelWidth} y={y + 3}
                  width={Math.max(0, x(r.value) - kLabelWidth)} height={kRow - 6} />
            <text class="value" x={x(r.value) + 4} y={y + kRow / 2 + 4}>{format(r.value)}</text>
          </g>
        );
      })}
    </svg>
  );
}

// The structured-light ground truth's own row (scored against the
// simulation) is a reference, not a method: the table shows it, the chart
// compares methods only.
const kGroundTruthMethod = "structured_light";

export function MetricsChart({ metrics: all }: { metrics: Metric[] }) {
  const metrics = all.filter((m) => m.method !== kGroundTruthMethod);
  const [bad, setBad] = useState<BadKey>("bad_1");
  const threshold = kBadThresholds.find((t) => t.key === bad)!;
  const truths = [...new Set(metrics.map((m) => m.groundTruth))];
  return (
    <div class="metrics-chart">
      <div class="field inline">
        <label for="bad-threshold">Bad pixels: error over</label>
        <select id="bad-threshold" value={bad}
                onChange={(e) => setBad(e.currentTarget.value as BadKey)}>
          {kBadThresholds.map((t) => <option key={t.key} value={t.key}>{t.label}</option>)}
        </select>
      </div>
      {truths.map((truth) => {
        const rows = metrics.filter((m) => m.groundTruth === truth);
        const slug = truth.replace(/[^a-z0-9]+/gi, "-");
        return (
          <figure key={truth} class="chart-pair">
            <figcaption>Against the <strong>{truth.replace(/_/g, " ")}</strong> ground truth
              ({rows.length} methods, best RMSE first)</figcaption>
            <div class="row chart-row">
              <Bars id={`rmse-${slug}`} title={`RMSE against ${truth}, pixels`} unit="RMSE (px)"
                    rows={rows.map((m) => ({ method: m.method, value: m.rmsePx }))}
                    format={formatPx} />
              <Bars id={`bad-${slug}`}
                    title={`Bad pixels over ${threshold.label} against ${truth}, percent`}
                    unit={`bad > ${threshold.label} (%)`}
                    rows={rows.map((m) => ({ method: m.method, value: m[threshold.field] as number }))}
                    format={formatPercent} />
            </div>
          </figure>
        );
      })}
    </div>
  );
}
