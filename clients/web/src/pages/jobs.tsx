// SPDX-License-Identifier: GPL-3.0-or-later
//
// Jobs: the queue and the history (#/jobs), and one job (#/jobs/<id>) with
// its live progress, remaining time, event log and controls. The event log
// is Jobs.Watch; a stream that breaks (network, daemon restart) is resumed
// after the last event held, so no event is shown twice or lost.
import { Code } from "@connectrpc/connect";
import { useEffect, useRef, useState } from "preact/hooks";
import {
  type Job, type JobEvent, JobEvent_Level, JobKind, JobState,
} from "../../gen/hdrstereo/v1/jobs_pb";
import { api, errorCode, errorMessage } from "../api";
import { gaps, lastSequence, mergeEvents, reconnectDelayMs } from "../event_log";
import { atLeast, Role, useMe } from "../identity";
import { remainingSeconds } from "../remaining";
import { href } from "../router";
import { Badge, ErrorBox, formatDuration, formatTime, Section, sleep, usePoll } from "../ui";
import { ConfirmButton } from "./form_parts";

const kStateWords: Record<JobState, [string, "ok" | "warn" | "bad" | "idle"]> = {
  [JobState.UNSPECIFIED]: ["unknown", "idle"],
  [JobState.QUEUED]: ["queued", "idle"],
  [JobState.RUNNING]: ["running", "ok"],
  [JobState.PAUSED]: ["paused", "warn"],
  [JobState.WAITING]: ["waiting for you", "warn"],
  [JobState.SUCCEEDED]: ["succeeded", "ok"],
  [JobState.FAILED]: ["failed", "bad"],
  [JobState.CANCELLED]: ["cancelled", "idle"],
  [JobState.INTERRUPTED]: ["interrupted", "bad"],
};

const kQueueStates = [JobState.QUEUED, JobState.RUNNING, JobState.PAUSED, JobState.WAITING];
const kFinalStates = [JobState.SUCCEEDED, JobState.FAILED, JobState.CANCELLED];
const kHistoryStates = [...kFinalStates, JobState.INTERRUPTED];

export function JobStateBadge({ state }: { state: JobState }) {
  const [words, tone] = kStateWords[state] ?? kStateWords[JobState.UNSPECIFIED];
  return <Badge tone={tone}>{words}</Badge>;
}

// "capture: structured light", "processing: hdr, tonemap".
export function jobWhat(job: Job): string {
  if (job.request.case === "capture") {
    const kind = job.request.value.plan.case;
    const words = kind === "bracketedStereo" ? "bracketed stereo"
      : kind === "structuredLight" ? "structured light" : kind ?? "";
    return `capture: ${words}`;
  }
  if (job.request.case === "processing") {
    const steps = job.request.value.steps;
    return `processing: ${steps.length > 0 ? steps.join(", ") : "every step"}`;
  }
  return job.kind === JobKind.CAPTURE ? "capture" : "processing";
}

export function JobsPage({ params }: { params: string[] }) {
  if (params.length > 0) return <JobPage id={params[0]} />;
  return <JobList />;
}

const kHistoryShown = 100;
const kQueueShown = 200;

// The newest `keep` jobs in `states` and how many there are: the daemon
// lists jobs oldest first, so every page is read.
async function newestJobs(states: JobState[], keep: number): Promise<{ jobs: Job[]; count: number }> {
  let jobs: Job[] = [];
  let count = 0;
  let pageToken = "";
  do {
    const page = await api.jobs.list({ states, page: { pageSize: 1000, pageToken } });
    count += page.jobs.length;
    jobs = [...jobs, ...page.jobs].slice(-keep);
    pageToken = page.nextPageToken;
  } while (pageToken !== "");
  return { jobs, count };
}

function JobList() {
  const [filter, setFilter] = useState<JobState | "all">("all");
  const states = filter === "all" ? null : [filter];
  const queue = usePoll(() => newestJobs(states ?? kQueueStates, kQueueShown), 2000, [filter]);
  const history = usePoll(
    () => (states ? Promise.resolve(null) : newestJobs(kHistoryStates, kHistoryShown)), 5000, [filter]);
  return (
    <section>
      <h1>Jobs</h1>
      <div class="field jobs-filter">
        <label for="job-state-filter">Show</label>
        <select id="job-state-filter" value={filter === "all" ? "all" : String(filter)}
                onChange={(e) => {
                  const v = e.currentTarget.value;
                  setFilter(v === "all" ? "all" : (Number(v) as JobState));
                }}>
          <option value="all">queue and history</option>
          {[...kQueueStates, ...kHistoryStates].map((s) => (
            <option key={s} value={String(s)}>{kStateWords[s][0]} only</option>
          ))}
        </select>
      </div>
      <Section title={states ? `Jobs ${kStateWords[states[0]][0]}` : "Queue"}>
        <ErrorBox error={queue.error} />
        <JobTable jobs={queue.value?.jobs}
                  order={states && kHistoryStates.includes(states[0]) ? "newest first" : "oldest first"}
                  empty={states ? "No job is in this state." : "Nothing queued or running."} />
        {queue.value && queue.value.count > kQueueShown && (
          <p class="muted">The newest {kQueueShown} of {queue.value.count}.</p>
        )}
      </Section>
      {!states && (
        <Section title="History">
          <ErrorBox error={history.error} />
          <JobTable jobs={history.value?.jobs ?? undefined} order="newest first" empty="No finished jobs yet." />
          {history.value && history.value.count > kHistoryShown && (
            <p class="muted">The newest {kHistoryShown} of {history.value.count} finished jobs.</p>
          )}
        </Section>
      )}
    </section>
  );
}

function JobTable({ jobs, order, empty }:
                  { jobs?: Job[]; order: "oldest first" | "newest first"; empty: string }) {
  if (!jobs) return <p class="muted">Loading…</p>;
  if (jobs.length === 0) return <p class="muted">{empty}</p>;
  const sorted = [...jobs].sort((a, b) =>
    (order === "oldest first" ? 1 : -1) * (a.id < b.id ? -1 : a.id > b.id ? 1 : 0));
  return (
    <div class="table-scroll">
      <table class="jobs-table">
        <thead>
          <tr>
            <th scope="col">Job</th><th scope="col">State</th><th scope="col">What</th>
            <th scope="col">Session</th><th scope="col">Submitted by</th>
            <th scope="col" class="num">Progress</th><th scope="col">Created</th>
            <th scope="col">Started</th><th scope="col">Ended</th>
          </tr>
        </thead>
        <tbody>
          {sorted.map((job) => (
            <tr key={String(job.id)} data-job-id={String(job.id)}>
              <td><a href={href("jobs", job.id)}>#{String(job.id)}</a></td>
              <td><JobStateBadge state={job.state} /></td>
              <td>{jobWhat(job)}</td>
              <td><a href={href("sessions", job.session)}>{job.session}</a></td>
              <td>{job.submittedBy || "–"}</td>
              <td class="num">
                {job.progress && job.progress.total > 0n
                  ? `${job.progress.done} / ${job.progress.total}` : "–"}
              </td>
              <td>{formatTime(job.createTime)}</td>
              <td>{formatTime(job.startTime)}</td>
              <td>{formatTime(job.endTime)}</td>
            </tr>
          ))}
        </tbody>
      </table>
    </div>
  );
}

function timeMs(t?: { seconds: bigint; nanos: number }): number {
  return t ? Number(t.seconds) * 1000 + t.nanos / 1e6 : 0;
}

type Connection =
  | { kind: "connecting" }
  | { kind: "live" }
  | { kind: "retrying"; inMs: number; attempt: number; why: string }
  | { kind: "ended" }
  | { kind: "failed"; why: string };

// Codes a retry cannot mend: the job is not there, the call is not
// allowed, the resumption point is wrong.
const kFatalCodes = [Code.NotFound, Code.InvalidArgument, Code.PermissionDenied,
                     Code.Unauthenticated, Code.OutOfRange];

// The job's events, streamed live and resumed after a break. Every state
// update first checks the effect's signal: a loop of an earlier job (or of
// an unmounted page) changes nothing once it is aborted.
function useJobEvents(jobId: bigint): { events: JobEvent[]; connection: Connection } {
  const [events, setEvents] = useState<JobEvent[]>([]);
  const [connection, setConnection] = useState<Connection>({ kind: "connecting" });
  useEffect(() => {
    const abort = new AbortController();
    const { signal } = abort;
    const connected = (c: Connection) => { if (!signal.aborted) setConnection(c); };
    let last = 0n;
    setEvents([]);
    setConnection({ kind: "connecting" });
    (async () => {
      let attempt = 0;
      while (!signal.aborted) {
        let why = "the stream ended before the job did";
        try {
          let finished = false;
          const stream = api.jobs.watch({ jobId, afterSequence: last }, {
            signal,
            // Connected: a job that is waiting may send nothing for long.
            onHeader: () => connected({ kind: "live" }),
          });
          for await (const event of stream) {
            if (signal.aborted) return;
            attempt = 0;
            if (event.sequence > last) last = event.sequence;
            setEvents((log) => mergeEvents(log, [event]));
            setConnection({ kind: "live" });
            if (kFinalStates.includes(event.state)) finished = true;
          }
          // A stream also ends for a job that will not go on (interrupted).
          if (!finished) finished = kHistoryStates.includes((await api.jobs.get({ jobId }, { signal })).state);
          if (signal.aborted) return;
          if (finished) {
            setConnection({ kind: "ended" });
            return;
          }
        } catch (e) {
          if (signal.aborted) return;
          const code = errorCode(e);
          if (code !== undefined && kFatalCodes.includes(code)) {
            setConnection({ kind: "failed", why: errorMessage(e) });
            return;
          }
          why = errorMessage(e);
        }
        const inMs = reconnectDelayMs(attempt, Math.random());
        ++attempt;
        connected({ kind: "retrying", inMs, attempt, why });
        await sleep(inMs, signal);
        connected({ kind: "connecting" });
      }
    })();
    return () => abort.abort();
  }, [jobId]);
  return { events, connection };
}

function ConnectionLine({ connection, held }: { connection: Connection; held: bigint }) {
  switch (connection.kind) {
    case "connecting":
      return <Badge tone="idle">connecting…</Badge>;
    case "live":
      return <Badge tone="ok">live</Badge>;
    case "ended":
      return <Badge tone="idle">complete: the job has ended</Badge>;
    case "failed":
      return <Badge tone="bad">stopped: {connection.why}</Badge>;
    case "retrying":
      return (
        <Badge tone="warn">
          connection lost ({connection.why}); reconnecting in {formatDuration(connection.inMs / 1000)},
          try {connection.attempt}, after event {String(held)}
        </Badge>
      );
  }
}

function JobPage({ id }: { id: string }) {
  const me = useMe();
  let jobId = 0n;
  try {
    jobId = BigInt(id);
  } catch {
    // not a number: shown below
  }
  const job = usePoll(() => api.jobs.get({ jobId }), 3000, [id]);
  const { events, connection } = useJobEvents(jobId);
  const newest = events.length > 0 ? events[events.length - 1] : undefined;

  // A state the stream shows before the next poll: read the job again for
  // what only Get says (suspension reason, instruction, error, times).
  const seenState = useRef<JobState | undefined>(undefined);
  useEffect(() => {
    if (newest && newest.state !== seenState.current) {
      seenState.current = newest.state;
      job.reload();
    }
  }, [newest?.state]);

  if (jobId <= 0n) return <section><h1>Job</h1><ErrorBox error={`"${id}" is not a job number`} /></section>;
  const j = job.value;
  if (!j) {
    return <section><h1>Job {id}</h1>{job.error ? <ErrorBox error={job.error} /> : <p class="muted">Loading…</p>}</section>;
  }
  // The stream is newer than the last poll while it runs.
  const state = newest && newest.sequence > 0n && !kFinalStates.includes(j.state) ? newest.state : j.state;
  const progress = newest?.progress ?? j.progress;
  const done = Number(progress?.done ?? 0n);
  const total = Number(progress?.total ?? 0n);
  const left = state === JobState.RUNNING
    ? remainingSeconds(events.filter((e) => e.progress).map((e) => ({
        timeMs: timeMs(e.time), done: Number(e.progress!.done), running: e.state === JobState.RUNNING,
      })), total)
    : undefined;
  const missing = gaps(events);

  return (
    <section class="job-page">
      <p><a href={href("jobs")}>← All jobs</a></p>
      <h1>Job #{String(j.id)} <JobStateBadge state={state} /></h1>
      {j.suspensionReason && (
        <p class="notice job-alert" role="status"><strong>Suspended:</strong> {j.suspensionReason}. It resumes by itself once this clears.</p>
      )}
      {state === JobState.WAITING && (
        <div class="notice job-alert" role="status">
          <p><strong>Waiting for you:</strong> {j.instruction || "the job waits for the operator"}</p>
          {atLeast(me, Role.OPERATOR) && <ContinueButton jobId={j.id} reload={job.reload} />}
          {j.kind === JobKind.CAPTURE && <p class="help">The live view shows whether the board is found: <a href={href("live")}>open live view</a>.</p>}
        </div>
      )}
      {state === JobState.FAILED && j.error && (
        <p class="error" role="alert"><strong>Failed:</strong> {j.error}</p>
      )}
      <ErrorBox error={job.error && `refreshing the job: ${job.error}`} />
      <Section title="Progress">
        <progress max={total > 0 ? total : undefined} value={total > 0 ? done : undefined}
                  aria-label={`Progress of job ${j.id}`} />
        <p class="job-progress">
          <strong>{total > 0 ? `${done} / ${total}` : "–"}</strong>
          {total > 0 && <span> ({Math.floor((100 * done) / total)} %)</span>}
          {progress?.step && <span> · {progress.step}</span>}
          {left !== undefined && <span> · about {formatDuration(left)} left</span>}
        </p>
        <JobControls job={j} state={state} canControl={atLeast(me, Role.OPERATOR)} reload={job.reload} />
      </Section>
      <Section title="Details">
        <dl class="facts">
          <dt>What</dt><dd>{jobWhat(j)}</dd>
          <dt>Session</dt><dd><a href={href("sessions", j.session)}>{j.session}</a></dd>
          <dt>Submitted by</dt><dd>{j.submittedBy || "–"}</dd>
          <dt>Created</dt><dd>{formatTime(j.createTime)}</dd>
          <dt>Started</dt><dd>{formatTime(j.startTime)}</dd>
          <dt>Ended</dt><dd>{formatTime(j.endTime)}</dd>
          {j.clusterJobId > 0n && <><dt>Slurm job</dt><dd>{String(j.clusterJobId)}</dd></>}
          {j.autoBracket && <><dt>Bracket chosen</dt><dd>{j.autoBracket.reason}</dd></>}
          {j.projectorTiming?.latencyS !== undefined && (
            <><dt>Projector latency</dt><dd>{(j.projectorTiming.latencyS * 1000).toFixed(0)} ms</dd></>
          )}
        </dl>
        {j.kind === JobKind.CAPTURE && !kHistoryStates.includes(state) && (
          <p><a href={href("live")}>Follow in live view</a> (it pauses for each frame and resumes after the capture).</p>
        )}
      </Section>
      <Section title="Event log">
        <p class="row"><ConnectionLine connection={connection} held={lastSequence(events)} /></p>
        {missing.length > 0 && (
          <p class="notice">Events not received: {missing.map((g) => g.from === g.to ? `${g.from}` : `${g.from}–${g.to}`).join(", ")}.</p>
        )}
        <EventList events={events} />
      </Section>
    </section>
  );
}

const kLevelWords: Record<JobEvent_Level, [string, "ok" | "warn" | "bad" | "idle"]> = {
  [JobEvent_Level.UNSPECIFIED]: ["note", "idle"],
  [JobEvent_Level.INFO]: ["info", "idle"],
  [JobEvent_Level.WARNING]: ["warning", "warn"],
  [JobEvent_Level.ERROR]: ["error", "bad"],
};

function EventList({ events }: { events: JobEvent[] }) {
  const box = useRef<HTMLDivElement>(null);
  // Whether the reader is at the newest event, read before this render
  // adds rows: then the list follows the new ones, otherwise it stays put.
  const el = box.current;
  const follow = !el || el.scrollHeight - el.scrollTop - el.clientHeight < 24;
  useEffect(() => {
    if (box.current && follow) box.current.scrollTop = box.current.scrollHeight;
  }, [events.length]);
  if (events.length === 0) return <p class="muted">No events yet.</p>;
  return (
    <div class="event-log" ref={box} role="log" aria-label="Job events" tabIndex={0}>
      <ol>
        {events.map((e) => {
          const [level, tone] = kLevelWords[e.level] ?? kLevelWords[JobEvent_Level.UNSPECIFIED];
          return (
            <li key={String(e.sequence)} data-sequence={String(e.sequence)} class={`event ${tone}`}>
              <span class="event-seq mono">{String(e.sequence)}</span>
              <time class="event-time mono" dateTime={new Date(timeMs(e.time)).toISOString()}>
                {new Date(timeMs(e.time)).toLocaleTimeString()}
              </time>
              {e.message
                ? <span class="event-text">{tone !== "idle" && <Badge tone={tone}>{level}</Badge>} {e.message}</span>
                : <span class="event-text muted">
                    {kStateWords[e.state]?.[0]}
                    {e.progress && e.progress.total > 0n && ` · ${e.progress.done} / ${e.progress.total}`}
                    {e.progress?.step && ` · ${e.progress.step}`}
                  </span>}
            </li>
          );
        })}
      </ol>
    </div>
  );
}

// Continue a waiting job (the operator has, e.g., placed the board).
function ContinueButton({ jobId, reload }: { jobId: bigint; reload: () => void }) {
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState<string | undefined>(undefined);
  return (
    <>
      <button type="button" disabled={busy} onClick={async () => {
        setBusy(true);
        setError(undefined);
        try {
          await api.jobs.continue({ jobId });
          reload();
        } catch (e) {
          setError(errorMessage(e));
        } finally {
          setBusy(false);
        }
      }}>Continue</button>
      <ErrorBox error={error} />
    </>
  );
}

function JobControls({ job, state, canControl, reload }:
                     { job: Job; state: JobState; canControl: boolean; reload: () => void }) {
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState<string | undefined>(undefined);
  if (!canControl || !kQueueStates.includes(state)) return null;
  const jobId = job.id;
  const act = async (call: () => Promise<unknown>) => {
    setBusy(true);
    setError(undefined);
    try {
      await call();
      reload();
    } catch (e) {
      setError(errorMessage(e));
    } finally {
      setBusy(false);
    }
  };
  return (
    <div class="job-controls">
      <div class="row">
        {state === JobState.RUNNING && (
          <button type="button" class="secondary" disabled={busy}
                  onClick={() => act(() => api.jobs.pause({ jobId }))}>Pause</button>
        )}
        {state === JobState.PAUSED && (
          <button type="button" disabled={busy} onClick={() => act(() => api.jobs.resume({ jobId }))}>
            Resume
          </button>
        )}
        <ConfirmButton label="Cancel job…" confirmLabel="Yes, cancel it" keepLabel="Keep it"
                       question={`Cancel job #${jobId}? The rig is left safe; frames taken are kept.`}
                       act={async () => {
                         await api.jobs.cancel({ jobId });
                         reload();
                       }} />
      </div>
      <ErrorBox error={error} />
    </div>
  );
}
