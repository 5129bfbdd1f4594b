// SPDX-License-Identifier: GPL-3.0-or-later
//
// Sessions and results: the list of sessions (#/sessions), one session
// (#/sessions/NAME: its frames with their check against the camera, its
// metrics as a table and as the thesis' comparison chart, its artifacts by
// step with downloads, the report), and one artifact viewed in place
// (#/sessions/NAME/artifacts/ID: the HDR viewer, the disparity viewer, an
// image). Everything here only reads, so a viewer sees all of it.
import { useState } from "preact/hooks";
import { CaptureKind, type Artifact, type Frame, type Metric, type Session } from "../../gen/hdrstereo/v1/sessions_pb";
import { api, errorMessage, fileUrl, reportUrl } from "../api";
import {
  artifactView, browserShowsImage, checkExposure, companionImages, coverageImages,
  extensionOf, formatPercent, formatPx, groundTruthOf, groupArtifacts, hex,
} from "../results";
import { formatExposure } from "../exposure";
import { atLeast, Role, useMe } from "../identity";
import { href } from "../router";
import { Badge, ErrorBox, formatBytes, formatTime, Section, usePoll } from "../ui";
import { DisparityViewer } from "../viewers/disparity_viewer";
import { HdrViewer } from "../viewers/hdr_viewer";
import { MetricsChart } from "../viewers/metrics_chart";

const kPageSize = 1000;
const kFramesShown = 12;  // per capture, until "Show all"

async function allFrames(session: string): Promise<Frame[]> {
  const out: Frame[] = [];
  let pageToken = "";
  do {
    const r = await api.sessions.listFrames({ session, page: { pageSize: kPageSize, pageToken } });
    out.push(...r.frames);
    pageToken = r.nextPageToken;
  } while (pageToken);
  return out;
}

async function allArtifacts(session: string): Promise<Artifact[]> {
  const out: Artifact[] = [];
  let pageToken = "";
  do {
    const r = await api.sessions.listArtifacts({ session, page: { pageSize: kPageSize, pageToken } });
    out.push(...r.artifacts);
    pageToken = r.nextPageToken;
  } while (pageToken);
  return out;
}

// --- The list -------------------------------------------------------------

function SessionList() {
  const [pages, setPages] = useState<string[]>([""]);
  const list = usePoll(async () => {
    const sessions: Session[] = [];
    let next = "";
    for (const pageToken of pages) {
      const r = await api.sessions.list({ page: { pageSize: 100, pageToken } });
      sessions.push(...r.sessions);
      next = r.nextPageToken;
    }
    return { sessions, next };
  }, 15000, [pages.length], { extends: true });
  const sessions = list.value?.sessions ?? [];
  return (
    <>
      <h1>Sessions</h1>
      <ErrorBox error={list.error} />
      {!list.value && !list.error && <p class="muted" role="status">Loading…</p>}
      {list.value && sessions.length === 0 && (
        <p>No sessions yet. An operator creates one on the Capture page or with
          <code> hdrstereo session create NAME</code>.</p>
      )}
      {sessions.length > 0 && (
        <div class="card table-wrap">
          <table class="sessions-table">
            <caption class="visually-hidden">Sessions, newest first as the server lists them</caption>
            <thead>
              <tr><th scope="col">Name</th><th scope="col">Created</th><th scope="col">Note</th>
                <th scope="col" class="num">Captures</th><th scope="col" class="num">Frames</th>
                <th scope="col" class="num">Artifacts</th></tr>
            </thead>
            <tbody>
              {sessions.map((s) => (
                <tr key={s.name} data-session={s.name}>
                  <th scope="row"><a href={href("sessions", s.name)}>{s.name}</a></th>
                  <td>{formatTime(s.createTime)}</td>
                  <td class="note">{s.note || <span class="muted">–</span>}</td>
                  <td class="num">{s.captureCount}</td>
                  <td class="num">{s.frameCount}</td>
                  <td class="num">{s.artifactCount}</td>
                </tr>
              ))}
            </tbody>
          </table>
          {list.value?.next && (
            <button type="button" class="secondary" onClick={() => setPages([...pages, list.value!.next])}>
              Show more sessions
            </button>
          )}
        </div>
      )}
    </>
  );
}

// --- Frames ---------------------------------------------------------------

const kCaptureKindName: Record<number, string> = {
  [CaptureKind.BRACKETED_STEREO]: "bracketed stereo",
  [CaptureKind.STRUCTURED_LIGHT]: "structured light",
  [CaptureKind.CALIBRATION]: "calibration",
};

function viewName(i: number): string {
  return i === 0 ? "left" : i === 1 ? "right" : `view ${i}`;
}

type HashState = { state: "checking" } | { state: "ok" } | { state: "bad"; got: string } | { state: "error"; message: string };

function FrameCard({ session, frame }: { session: string; frame: Frame }) {
  const [hash, setHash] = useState<HashState | undefined>(undefined);
  const url = fileUrl(session, "frames", frame.id);
  const exposure = checkExposure(frame.exposureS, frame.cameraExposureS);
  const what = `${viewName(frame.viewIndex)}, ${formatExposure(frame.exposureS)}` +
    (frame.pattern ? `, ${frame.pattern}${frame.inverse ? " inverse" : ""}` : "");
  const verify = async () => {
    setHash({ state: "checking" });
    try {
      const response = await fetch(url, { credentials: "same-origin" });
      if (!response.ok) throw new Error(`HTTP ${response.status}`);
      const digest = hex(await crypto.subtle.digest("SHA-256", await response.arrayBuffer()));
      setHash(digest === frame.sha256.toLowerCase() ? { state: "ok" } : { state: "bad", got: digest });
    } catch (e) {
      setHash({ state: "error", message: errorMessage(e) });
    }
  };
  return (
    <li class="frame-card" data-frame={String(frame.id)} data-exposure-check={exposure.state}>
      {browserShowsImage(frame.path) ? (
        <a href={url} target="_blank" rel="noopener" class="thumb"
           aria-label={`Frame ${frame.id} (${what}) at full size, in a new tab`}>
          <img src={url} alt="" loading="lazy" decoding="async" width={160}
               height={frame.widthPx > 0 ? Math.round((160 * frame.heightPx) / frame.widthPx) : 120} />
        </a>
      ) : (
        <div class="thumb placeholder" role="img"
             aria-label={`Frame ${frame.id}: ${extensionOf(frame.path)}, which a browser cannot show`}>
          <span>{extensionOf(frame.path)}</span>
          <span class="muted">no preview in a browser</span>
        </div>
      )}
      <div class="frame-facts">
        <strong>#{frame.sequence}</strong> {what}
        <div class="muted">{frame.widthPx}×{frame.heightPx}, {frame.cameraFileName || frame.path.split("/").pop()}</div>
        <div>
          {exposure.state === "match" && <Badge tone="ok">exposure as set</Badge>}
          {exposure.state === "differs" && <Badge tone="bad">exposure differs</Badge>}
          {exposure.state === "unreported" && <Badge tone="idle">exposure not reported</Badge>}
          <span class="check-text"> {exposure.text}
            {frame.iso !== undefined && `, ISO ${frame.iso}`}
            {frame.apertureF !== undefined && `, f/${frame.apertureF}`}</span>
        </div>
        <div>
          sha256 <code title={frame.sha256}>{frame.sha256.slice(0, 12)}…</code>{" "}
          {hash === undefined && (
            <button type="button" class="secondary small" onClick={verify}>
              Check file<span class="visually-hidden"> of frame {String(frame.id)} against its sha256</span>
            </button>
          )}
          {hash?.state === "checking" && <span role="status">checking…</span>}
          {hash?.state === "ok" && <Badge tone="ok">file matches</Badge>}
          {hash?.state === "bad" && <Badge tone="bad">file differs: {hash.got.slice(0, 12)}…</Badge>}
          {hash?.state === "error" && <Badge tone="bad">{hash.message}</Badge>}
        </div>
      </div>
    </li>
  );
}

function FramesSection({ session, frames }: { session: string; frames: Frame[] }) {
  const [expanded, setExpanded] = useState<Set<bigint>>(new Set());
  const captures = [...new Set(frames.map((f) => f.captureId))];
  const differs = frames.filter((f) => checkExposure(f.exposureS, f.cameraExposureS).state === "differs").length;
  const unreported = frames.filter((f) => f.cameraExposureS === undefined).length;
  return (
    <Section title={`Frames (${frames.length})`}>
      {frames.length === 0 && <p class="muted">No frames recorded.</p>}
      {frames.length > 0 && (
        <p class="help" data-testid="frame-summary">
          Each frame's exposure as the camera wrote it into the file, against the exposure set
          (within 1/6 stop counts as set): {frames.length - differs - unreported} as set,
          {" "}{differs} differ, {unreported} not reported. The sha256 is the daemon's, taken
          when the file came off the camera; “Check file” downloads it and compares.
        </p>
      )}
      {captures.map((c) => {
        const of = frames.filter((f) => f.captureId === c);
        const all = expanded.has(c);
        const shown = all ? of : of.slice(0, kFramesShown);
        return (
          <div key={String(c)} class="capture">
            <h3>Capture {String(c)}: {kCaptureKindName[of[0].captureKind] ?? "capture"}, {of.length} frames</h3>
            <ul class="frame-grid">
              {shown.map((f) => <FrameCard key={String(f.id)} session={session} frame={f} />)}
            </ul>
            {of.length > kFramesShown && (
              <button type="button" class="secondary"
                      onClick={() => {
                        const next = new Set(expanded);
                        if (all) next.delete(c); else next.add(c);
                        setExpanded(next);
                      }}>
                {all ? `Show the first ${kFramesShown}` : `Show all ${of.length} frames`}
              </button>
            )}
          </div>
        );
      })}
    </Section>
  );
}

// --- Metrics --------------------------------------------------------------

function MetricsTable({ metrics }: { metrics: Metric[] }) {
  const px = (v: number) => <td class="num" title={String(v)} data-value={String(v)}>{formatPx(v)}</td>;
  const pc = (v: number) => <td class="num" title={String(v)} data-value={String(v)}>{formatPercent(v)}</td>;
  return (
    <div class="table-wrap">
      <table class="metrics-table" data-testid="metrics-table">
        <caption>Pixels (px) to 3 decimals, percentages to 1; the exact value is in each
          cell's tooltip. Bad: the share of scored pixels whose error exceeds the threshold.
          Coverage: ground-truth pixels with a disparity. Versus LDR: a method whose RMSE is
          above the single middle exposure's against the same ground truth.</caption>
        <thead>
          <tr><th scope="col">Ground truth</th><th scope="col">Method</th>
            <th scope="col" class="num">RMSE</th><th scope="col" class="num">MAE</th>
            <th scope="col" class="num">Bad &gt; 0.5</th><th scope="col" class="num">Bad &gt; 1</th>
            <th scope="col" class="num">Bad &gt; 2</th><th scope="col" class="num">Bad &gt; 4</th>
            <th scope="col" class="num">Coverage</th><th scope="col">Versus LDR</th></tr>
        </thead>
        <tbody>
          {metrics.map((m) => (
            <tr key={`${m.groundTruth}/${m.method}`} data-truth={m.groundTruth} data-method={m.method}>
              <td>{m.groundTruth.replace(/_/g, " ")}</td>
              <th scope="row">{m.method}</th>
              {px(m.rmsePx)}{px(m.maePx)}{pc(m.bad05)}{pc(m.bad1)}{pc(m.bad2)}{pc(m.bad4)}{pc(m.coverage)}
              <td data-worse-than-ldr={String(m.worseThanLdr)}>{m.worseThanLdr ? "worse than LDR" : ""}</td>
            </tr>
          ))}
        </tbody>
      </table>
    </div>
  );
}

// --- Artifacts ------------------------------------------------------------

function viewLabel(a: Artifact): string | undefined {
  switch (artifactView(a)) {
    case "hdr": return "View (HDR)";
    case "disparity": return "View (disparity)";
    case "image": return "View";
    default: return undefined;
  }
}

function ArtifactsSection({ session, artifacts }: { session: string; artifacts: Artifact[] }) {
  const groups = groupArtifacts(artifacts);
  return (
    <Section title={`Artifacts (${artifacts.length})`}>
      {artifacts.length === 0 && <p class="muted">Nothing processed yet.</p>}
      {groups.map((g) => (
        <details key={g.kind} class="artifact-group" data-kind={g.kind}>
          <summary><strong>{g.kind}</strong> — {g.artifacts.length} file{g.artifacts.length === 1 ? "" : "s"},
            {" "}{formatBytes(g.artifacts.reduce((n, a) => n + Number(a.sizeBytes), 0))}</summary>
          <table>
            <thead><tr><th scope="col">File</th><th scope="col" class="num">Size</th>
              <th scope="col">Job</th><th scope="col">Open</th></tr></thead>
            <tbody>
              {g.artifacts.map((a) => {
                const label = viewLabel(a);
                return (
                  <tr key={String(a.id)} data-artifact={String(a.id)}>
                    <td><code>{a.path}</code></td>
                    <td class="num">{formatBytes(a.sizeBytes)}</td>
                    <td>{String(a.jobId)}</td>
                    <td class="row">
                      {label && <a href={href("sessions", session, "artifacts", a.id)}>{label}<span class="visually-hidden"> {a.path}</span></a>}
                      <a href={fileUrl(session, "artifacts", a.id)} download={a.path.split("/").pop()}>
                        Download<span class="visually-hidden"> {a.path}</span></a>
                    </td>
                  </tr>
                );
              })}
            </tbody>
          </table>
        </details>
      ))}
    </Section>
  );
}

// The shortcuts an operator opens first: the radiance maps, the fused
// disparity, the ground truth, the report.
function ResultLinks({ session, artifacts }: { session: string; artifacts: Artifact[] }) {
  const byPath = (p: string) => artifacts.find((a) => a.path === p);
  const links = [
    { a: byPath("hdr/im0.pfm"), text: "HDR radiance map, left" },
    { a: byPath("hdr/im1.pfm"), text: "HDR radiance map, right" },
    { a: byPath("disparity/fused.pfm"), text: "Fused disparity" },
    { a: byPath("disparity/hdr.pfm"), text: "HDR disparity" },
    { a: groundTruthOf(artifacts), text: "Structured-light ground truth" },
  ].filter((l) => l.a);
  const report = byPath("report/index.html");
  if (links.length === 0 && !report) return null;
  return (
    <Section title="Results">
      <ul class="result-links">
        {links.map((l) => (
          <li key={l.text}><a href={href("sessions", session, "artifacts", l.a!.id)}>{l.text}</a></li>
        ))}
        {report && (
          <li>
            <a href={reportUrl(session)} target="_blank" rel="noopener"
               data-testid="report-link">HTML report (opens in a new tab)</a>{" · "}
            <a href={fileUrl(session, "artifacts", report.id)} download="report.html">download it</a>{" "}
            <span class="help">The page shows its images but runs no script; the download
              is the page alone (its images are the artifacts under “report” below).</span>
          </li>
        )}
      </ul>
      <CoverageImages session={session} artifacts={artifacts} />
    </Section>
  );
}

function CoverageImages({ session, artifacts }: { session: string; artifacts: Artifact[] }) {
  const images = coverageImages(artifacts);
  if (images.length === 0) return null;
  return (
    <>
      <h3>Ground-truth coverage</h3>
      <ul class="image-strip">
        {images.map((a) => (
          <li key={String(a.id)}>
            <a href={href("sessions", session, "artifacts", a.id)}>
              <img src={fileUrl(session, "artifacts", a.id)} alt={a.path} loading="lazy" width={240} />
            </a>
            <div class="muted"><code>{a.path}</code></div>
          </li>
        ))}
      </ul>
    </>
  );
}

// --- One session, one artifact --------------------------------------------

// Operators (and admins) start processing here; a viewer does not see it.
function ProcessControl({ session }: { session: string }) {
  const me = useMe();
  const [force, setForce] = useState(false);
  const [busy, setBusy] = useState(false);
  const [job, setJob] = useState<bigint | undefined>(undefined);
  const [error, setError] = useState<string | undefined>(undefined);
  if (!atLeast(me, Role.OPERATOR)) return null;
  const submit = async () => {
    setBusy(true);
    setError(undefined);
    setJob(undefined);
    try {
      const j = await api.jobs.submitProcessing({ session, force });
      setJob(j.id);
    } catch (e) {
      setError(errorMessage(e));
    } finally {
      setBusy(false);
    }
  };
  return (
    <div class="process-control">
      <div class="row">
        <button type="button" onClick={submit} disabled={busy}>Process this session</button>
        <label class="choice">
          <input type="checkbox" checked={force} onChange={(e) => setForce(e.currentTarget.checked)} />
          recompute every step, also those whose inputs did not change
        </label>
      </div>
      {job !== undefined && (
        <p role="status">Processing job {String(job)} submitted:{" "}
          <a href={href("jobs", job)}>follow it on the Jobs page</a>; reload this page when it is done.</p>
      )}
      <ErrorBox error={error} />
    </div>
  );
}

function SessionView({ name }: { name: string }) {
  const data = usePoll(async () => {
    // The session first: a name that is not there is one refusal, not four.
    const session = await api.sessions.get({ name });
    const [frames, artifacts, metrics] = await Promise.all([
      allFrames(name), allArtifacts(name), api.sessions.listMetrics({ session: name }),
    ]);
    return { session, frames, artifacts, metrics: metrics.metrics };
  }, 0, [name]);
  const v = data.value;
  return (
    <>
      <p><a href={href("sessions")}>← All sessions</a></p>
      <h1>Session {name}</h1>
      <ErrorBox error={data.error} />
      {!v && !data.error && <p class="muted" role="status">Loading…</p>}
      {v && (
        <>
          <Section title="About">
            <dl class="facts">
              <dt>Created</dt><dd>{formatTime(v.session.createTime)}</dd>
              <dt>Note</dt><dd>{v.session.note || "–"}</dd>
              <dt>Folder on the server</dt><dd><code>{v.session.path}</code></dd>
              <dt>Captures</dt><dd>{v.session.captureCount}</dd>
              <dt>Frames</dt><dd>{v.session.frameCount}</dd>
              <dt>Artifacts</dt><dd>{v.session.artifactCount}</dd>
            </dl>
            <div class="row session-actions">
              <button type="button" class="secondary" onClick={data.reload}>Reload</button>
            </div>
            <ProcessControl session={name} />
          </Section>
          <ResultLinks session={name} artifacts={v.artifacts} />
          <Section title="Metrics">
            {v.metrics.length === 0
              ? <p class="muted">No evaluation yet: process the session with a ground truth.</p>
              : <><MetricsTable metrics={v.metrics} /><h3>Comparison of methods</h3>
                  <MetricsChart metrics={v.metrics} /></>}
          </Section>
          <FramesSection session={name} frames={v.frames} />
          <ArtifactsSection session={name} artifacts={v.artifacts} />
        </>
      )}
    </>
  );
}

function ArtifactPage({ session, id }: { session: string; id: string }) {
  const data = usePoll(() => allArtifacts(session), 0, [session]);
  const artifacts = data.value ?? [];
  const a = artifacts.find((x) => String(x.id) === id);
  const url = a ? fileUrl(session, "artifacts", a.id) : "";
  const truth = groundTruthOf(artifacts);
  return (
    <>
      <p><a href={href("sessions", session)}>← Session {session}</a></p>
      <h1>{a ? <code>{a.path}</code> : `Artifact ${id}`}</h1>
      <ErrorBox error={data.error} />
      {data.value && !a && <p class="error" role="alert">Session {session} has no artifact {id}.</p>}
      {a && (
        <>
          <p class="row">
            <Badge tone="idle">{a.kind}</Badge>
            <span>{formatBytes(a.sizeBytes)}, job {String(a.jobId)}, {formatTime(a.createTime)}</span>
            <a href={url} download={a.path.split("/").pop()}>Download</a>
            <code title={a.sha256}>sha256 {a.sha256.slice(0, 12)}…</code>
          </p>
          <div class="card">
            {artifactView(a) === "hdr" && <HdrViewer key={url} url={url} label={a.path} />}
            {artifactView(a) === "disparity" && (
              truth && truth.id !== a.id
                ? <DisparityViewer key={url} url={url} label={a.path}
                                   truthUrl={fileUrl(session, "artifacts", truth.id)} truthLabel={truth.path} />
                : <DisparityViewer key={url} url={url} label={a.path}
                                   truthNote={truth ? "this map is the session's ground truth" : undefined} />
            )}
            {artifactView(a) === "image" && <img class="artifact-image" src={url} alt={a.path} />}
            {artifactView(a) === "download" && (
              <p>{extensionOf(a.path)} file: not shown in the browser; use Download.</p>
            )}
          </div>
          {companionImages(a, artifacts).length > 0 && (
            <Section title="Beside it">
              <ul class="image-strip">
                {companionImages(a, artifacts).map((c) => (
                  <li key={String(c.id)}>
                    <a href={href("sessions", session, "artifacts", c.id)}>
                      <img src={fileUrl(session, "artifacts", c.id)} alt={c.path} loading="lazy" width={360} />
                    </a>
                    <div class="muted"><code>{c.path}</code></div>
                  </li>
                ))}
              </ul>
            </Section>
          )}
          {a.paramsJson && (
            <details class="card">
              <summary>Parameters of the step that made it</summary>
              <pre class="params">{a.paramsJson}</pre>
            </details>
          )}
        </>
      )}
    </>
  );
}

export function SessionsPage({ params }: { params: string[] }) {
  const [name, sub, id] = params;
  if (!name) return <SessionList />;
  if (sub === "artifacts" && id) return <ArtifactPage session={name} id={id} />;
  return <SessionView name={name} />;
}
