// SPDX-License-Identifier: GPL-3.0-or-later
//
// The rig at a glance, updated live: the camera, the stage (home, move),
// the projector and its timing, the rig lock, the disk against what the
// queued captures need, and the jobs under way with any suspension.
// Controls show only for the roles that may use them: an operator moves
// the stage, probes the projector and takes the lock; an admin also
// force-releases someone else's lock.
import { useRef, useState } from "preact/hooks";
import { api, errorMessage } from "../api";
import { type CameraStatus, DeviceState, type ProjectorProbe, type RigLock } from "../../gen/hdrstereo/v1/hardware_pb";
import { type Job, JobKind, JobState, type ProjectorTiming } from "../../gen/hdrstereo/v1/jobs_pb";
import { atLeast, Role, useMe } from "../identity";
import { href } from "../router";
import { Badge, ErrorBox, formatBytes, formatDuration, formatTime, type Loaded, Section, usePoll } from "../ui";

const kPollMs = 1500;
const kActiveStates = [JobState.RUNNING, JobState.PAUSED, JobState.WAITING];

// Runs `call` with a busy flag and the server's message on failure.
function useAction() {
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState<string | undefined>(undefined);
  const run = async <T,>(call: () => Promise<T>): Promise<T | undefined> => {
    setBusy(true);
    setError(undefined);
    try {
      return await call();
    } catch (e) {
      setError(errorMessage(e));
      return undefined;
    } finally {
      setBusy(false);
    }
  };
  return { busy, error, run };
}

function DeviceBadge({ state, attempt }: { state: DeviceState; attempt?: number }) {
  switch (state) {
    case DeviceState.CONNECTED: return <Badge tone="ok">connected</Badge>;
    case DeviceState.BUSY: return <Badge tone="ok">busy</Badge>;
    case DeviceState.DISCONNECTED: return <Badge tone="bad">disconnected</Badge>;
    case DeviceState.FAULT: return <Badge tone="bad">fault</Badge>;
    case DeviceState.RECONNECTING:
      return <Badge tone="warn">reconnecting{attempt ? ` (attempt ${attempt})` : ""}</Badge>;
    default: return <Badge tone="idle">unknown</Badge>;
  }
}

function formatMm(mm: number): string {
  return `${mm.toFixed(2)} mm`;
}

export function RigPage() {
  const me = useMe();
  const operator = atLeast(me, Role.OPERATOR);
  const status = usePoll(() => api.hardware.getStatus({}), kPollMs);
  const lock = usePoll(() => api.hardware.getLock({}), kPollMs);
  const info = usePoll(() => api.server.getInfo({}), kPollMs * 2);
  const jobs = usePoll(() => api.jobs.list({ states: kActiveStates }), kPollMs);
  const active = jobs.value?.jobs ?? [];
  // A structured-light capture under way knows its projector's timing (Get
  // only: List leaves it out).
  const structured = active.find((j) => j.kind === JobKind.CAPTURE &&
                                         j.request.case === "capture" &&
                                         j.request.value.plan.case === "structuredLight");
  const timing = usePoll(async () => (structured ? (await api.jobs.get({ jobId: structured.id })).projectorTiming : undefined),
                         kPollMs * 2, [structured?.id]);
  const hw = status.value;

  return (
    <div class="rig">
      <h1>Rig</h1>
      <p class="help">
        Updated every {kPollMs / 1000} s{hw ? `; ${hw.hardwareMode === "sim" ? "simulated" : "real"} hardware` : ""}.
      </p>
      <ErrorBox error={status.error} />
      <div class="grid">
        <CameraCard camera={hw?.camera} error={status.error} />
        <StageCard status={hw?.stage} operator={operator} onChange={status.reload} />
        <ProjectorCard status={hw?.projector} timing={timing.value} timingJob={structured}
                       operator={operator} onChange={status.reload} />
        <LockCard lock={lock} operator={operator} admin={atLeast(me, Role.ADMIN)} principal={me.principal} />
        <Section title="Disk">
          <ErrorBox error={info.error} />
          {info.value && <Disk free={info.value.dataRootFreeBytes} pending={info.value.pendingCaptureBytes}
                               root={info.value.dataRoot} />}
        </Section>
        <Section title="Jobs under way">
          <ErrorBox error={jobs.error} />
          {jobs.value && (active.length === 0
            ? <p><Badge tone="idle">idle</Badge> No job is running, paused or waiting.</p>
            : <ul class="rig-jobs">{active.map((j) => <ActiveJob key={String(j.id)} job={j} />)}</ul>)}
        </Section>
      </div>
    </div>
  );
}

function CameraCard({ camera, error }: { camera?: CameraStatus; error?: string }) {
  // While a capture or another call holds the rig the status says only
  // that: show the camera's facts as last seen.
  const lastSeen = useRef<CameraStatus | undefined>(undefined);
  if (camera?.model) lastSeen.current = camera;
  const facts = camera?.model ? camera : lastSeen.current;
  if (!camera) return <Section title="Camera"><p class="muted">{error ? "Unknown." : "Loading…"}</p></Section>;
  return (
    <Section title="Camera">
      <p><DeviceBadge state={camera.state} attempt={camera.reconnectAttempt} />
        {camera.message && <> {camera.message}</>}</p>
      {facts && (
        <dl class="facts">
          <dt>Model</dt><dd>{facts.model}</dd>
          {facts.serial && <><dt>Serial</dt><dd>{facts.serial}</dd></>}
          {facts.port && <><dt>Port</dt><dd class="mono">{facts.port}</dd></>}
          <dt>Battery</dt>
          <dd>{facts.batteryPercent >= 0
            ? <><meter min={0} max={100} low={20} optimum={100} value={facts.batteryPercent}
                       aria-label="Battery" /> {facts.batteryPercent} %{facts.batteryPercent < 20 && " (low)"}</>
            : "unknown"}</dd>
          <dt>Drops</dt><dd>{String(facts.disconnects)} since the daemon started</dd>
        </dl>
      )}
      {facts && facts !== camera && <p class="help">As last seen.</p>}
    </Section>
  );
}

function StageCard({ status, operator, onChange }: {
  status?: { state: DeviceState; positionMm: number; homed: boolean; travelMm: number;
             warningFlags: string[]; message: string };
  operator: boolean; onChange: () => void;
}) {
  const [target, setTarget] = useState("");
  const action = useAction();
  // While a capture or another call holds the rig the status has no stage
  // data (travel 0): bound the input by the travel last seen.
  const knownTravel = useRef(0);
  if (status && status.travelMm > 0) knownTravel.current = status.travelMm;
  const travel = knownTravel.current;
  const value = Number(target);
  const valid = target.trim() !== "" && Number.isFinite(value) && value >= 0 && value <= travel;
  const move = async (e: Event) => {
    e.preventDefault();
    if (valid && await action.run(() => api.hardware.moveStage({ positionMm: value }))) onChange();
  };
  const home = async () => {
    if (await action.run(() => api.hardware.homeStage({}))) onChange();
  };
  return (
    <Section title="Stage">
      {status ? (
        <>
          <p><DeviceBadge state={status.state} />{status.message && <> {status.message}</>}</p>
          <dl class="facts">
            {status.travelMm > 0 && <>
              <dt>Position</dt><dd data-testid="stage-position">{formatMm(status.positionMm)}</dd>
              <dt>Homed</dt><dd>{status.homed ? "yes" : "no: home it before moving"}</dd>
            </>}
            {travel > 0 && <><dt>Travel</dt><dd>0 – {formatMm(travel)}</dd></>}
            {status.warningFlags.length > 0 && <><dt>Warnings</dt><dd>{status.warningFlags.join(", ")}</dd></>}
          </dl>
          {operator && (
            <form class="rig-stage-form" onSubmit={move}>
              <div class="field">
                <label for="stage-target">Move to (mm)</label>
                <div class="row">
                  <input id="stage-target" type="number" min={0} max={travel} step="any" value={target}
                         onInput={(e) => setTarget(e.currentTarget.value)}
                         aria-invalid={target !== "" && !valid ? "true" : undefined}
                         aria-describedby="stage-target-help" />
                  <button type="submit" disabled={action.busy || !valid}>Move</button>
                  <button type="button" class="secondary" disabled={action.busy} onClick={home}>Home</button>
                </div>
                <p id="stage-target-help" class="help">
                  {travel > 0 ? `Absolute, from 0 to ${formatMm(travel)}.`
                              : "Absolute; the travel is read once the rig is free."}
                </p>
              </div>
            </form>
          )}
          <ErrorBox error={action.error} />
        </>
      ) : <p class="muted">Loading…</p>}
    </Section>
  );
}

function describeTiming(t: ProjectorTiming | undefined): string | undefined {
  if (!t) return undefined;
  const parts = [
    t.latencyS !== undefined ? `latency ${(t.latencyS * 1000).toFixed(0)} ms` : "latency not recorded",
    t.refreshHz !== undefined ? `refresh ${t.refreshHz.toFixed(2)} Hz` : "refresh rate not recorded",
  ];
  return parts.join(", ");
}

function ProjectorCard({ status, timing, timingJob, operator, onChange }: {
  status?: { state: DeviceState; widthPx: number; heightPx: number; showing: string; message: string };
  timing?: ProjectorTiming; timingJob?: Job; operator: boolean; onChange: () => void;
}) {
  const [probe, setProbe] = useState<ProjectorProbe | undefined>(undefined);
  const action = useAction();
  const measure = async () => {
    const p = await action.run(() => api.hardware.probeProjector({}));
    if (p) {
      setProbe(p);
      onChange();
    }
  };
  const jobTiming = describeTiming(timing);
  return (
    <Section title="Projector">
      {status ? (
        <>
          <p><DeviceBadge state={status.state} />{status.message && <> {status.message}</>}</p>
          <dl class="facts">
            <dt>Showing</dt><dd>{status.showing || "–"}</dd>
            <dt>Resolution</dt><dd>{status.widthPx > 0 ? `${status.widthPx} × ${status.heightPx}` : "–"}</dd>
            <dt>Timing</dt>
            <dd>
              {jobTiming && timingJob && <>{jobTiming} (<a href={href("jobs", String(timingJob.id))}>job {String(timingJob.id)}</a>)<br /></>}
              {probe && <>latency {(probe.latencyS * 1000).toFixed(0)} ms (± {(probe.stepS * 1000).toFixed(0)} ms),{" "}
                {probe.refreshHz > 0 ? `refresh ${probe.refreshHz.toFixed(2)} Hz` : `refresh unknown: ${probe.refreshError}`}
                {" "}(measured here)</>}
              {!jobTiming && !probe && "not known: a structured-light capture or a probe measures it"}
            </dd>
          </dl>
          {operator && (
            <p>
              <button type="button" class="secondary" disabled={action.busy} onClick={measure}>
                {action.busy ? "Measuring…" : "Measure latency"}
              </button>
            </p>
          )}
          <ErrorBox error={action.error} />
        </>
      ) : <p class="muted">Loading…</p>}
    </Section>
  );
}

const kTtlChoices: [string, number][] = [
  ["15 minutes", 900], ["1 hour", 3600], ["4 hours", 14400], ["8 hours", 28800],
  ["1 day", 86400], ["7 days", 604800],
];

function LockCard({ lock, operator, admin, principal }: {
  lock: Loaded<RigLock>;
  operator: boolean; admin: boolean; principal: string;
}) {
  const [note, setNote] = useState("");
  const [ttl, setTtl] = useState(3600);
  const action = useAction();
  const l = lock.value;
  const mine = l?.locked && l.holder === principal;
  const other = l?.locked && !mine;
  const take = async (e: Event) => {
    e.preventDefault();
    if (await action.run(() => api.hardware.lock({ note, ttlS: BigInt(ttl) }))) lock.reload();
  };
  const release = async (force: boolean) => {
    if (await action.run(() => api.hardware.unlock({ force }))) lock.reload();
  };
  return (
    <Section title="Rig lock">
      <ErrorBox error={lock.error} />
      {l && (l.locked ? (
        <>
          <p><Badge tone="warn">locked</Badge> by <strong>{l.holder}</strong>{mine && " (you)"}</p>
          <dl class="facts">
            <dt>Why</dt><dd>{l.note || "no note"}</dd>
            <dt>Since</dt><dd>{formatTime(l.lockTime)}</dd>
            <dt>Until</dt><dd>{formatTime(l.expireTime)}</dd>
          </dl>
          {other && <p class="help">Others' captures and moves are refused while it is held.</p>}
        </>
      ) : <p><Badge tone="ok">free</Badge> Nobody holds the rig lock.</p>)}
      {l && operator && !other && (
        <form class="rig-lock-form" onSubmit={take}>
          <div class="field">
            <label for="lock-note">Why (shown to people refused)</label>
            <input id="lock-note" maxLength={1024} value={note} onInput={(e) => setNote(e.currentTarget.value)}
                   placeholder="e.g. re-aligning the projector" />
          </div>
          <div class="field">
            <label for="lock-ttl">For</label>
            <select id="lock-ttl" value={ttl} onChange={(e) => setTtl(Number(e.currentTarget.value))}>
              {kTtlChoices.map(([label, s]) => <option key={s} value={s}>{label}</option>)}
            </select>
          </div>
          <div class="row">
            <button type="submit" disabled={action.busy}>{mine ? "Renew the lock" : "Take the lock"}</button>
            {mine && <button type="button" class="secondary" disabled={action.busy}
                             onClick={() => release(false)}>Release</button>}
          </div>
        </form>
      )}
      {other && admin && (
        <p>
          <button type="button" class="danger" disabled={action.busy} onClick={() => release(true)}>
            Force release ({l?.holder}'s lock)
          </button>
        </p>
      )}
      <ErrorBox error={action.error} />
    </Section>
  );
}

function Disk({ free, pending, root }: { free: bigint; pending: bigint; root: string }) {
  const short = pending > free;
  return (
    <>
      <dl class="facts">
        <dt>Free</dt><dd>{formatBytes(free)}</dd>
        <dt>Queued captures need</dt><dd>{formatBytes(pending)}</dd>
      </dl>
      <p class="help">On the data root, <span class="mono">{root}</span>.</p>
      {short ? (
        <p class="notice" role="alert">
          <strong>▲ Not enough disk space:</strong> the queued captures need {formatBytes(pending)} but only{" "}
          {formatBytes(free)} is free ({formatBytes(pending - free)} short). Free space on the data root or
          cancel a capture, or the captures will stop.
        </p>
      ) : (
        <p><Badge tone="ok">enough space</Badge>{pending > 0n && ` ${formatBytes(free - pending)} to spare`}</p>
      )}
    </>
  );
}

function ActiveJob({ job }: { job: Job }) {
  const p = job.progress;
  const kind = job.kind === JobKind.CAPTURE ? "capture" : "processing";
  const elapsed = job.startTime ? (Date.now() - Number(job.startTime.seconds) * 1000) / 1000 : undefined;
  const tone = job.state === JobState.RUNNING ? "ok" : "warn";
  return (
    <li>
      <a href={href("jobs", String(job.id))}>Job {String(job.id)}</a>: {kind}, session {job.session}{" "}
      <Badge tone={tone}>{JobState[job.state].toLowerCase()}</Badge>
      {p && p.total > 0n && (
        <div class="row">
          <progress max={Number(p.total)} value={Number(p.done)} aria-label={`Job ${job.id} progress`} />
          <span>{String(p.done)} of {String(p.total)}{p.step && ` · ${p.step}`}</span>
        </div>
      )}
      {(!p || p.total === 0n) && p?.step && <div>{p.step}</div>}
      {elapsed !== undefined && <div class="help">running for {formatDuration(elapsed)}, by {job.submittedBy || "–"}</div>}
      {job.suspensionReason && <p class="notice"><strong>▲ Suspended:</strong> {job.suspensionReason}</p>}
      {job.instruction && <p class="notice"><strong>Waiting for you:</strong> {job.instruction}</p>}
    </li>
  );
}
