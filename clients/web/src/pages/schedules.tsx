// SPDX-License-Identifier: GPL-3.0-or-later
//
// Schedules: each with when it runs (cron, in words where it can), its
// plan, whether it is enabled, its next run and its runs with their
// outcomes. Admins also create, enable, disable and delete (the daemon's
// role table: Schedules.List and ListRuns need viewer, the rest admin).
import { useState } from "preact/hooks";
import { api, errorMessage } from "../api";
import { MissedRunPolicy, type Schedule, type ScheduleRun } from "../../gen/hdrstereo/v1/schedules_pb";
import { type FormErrors, kNoErrors, placeError } from "../field_errors";
import { atLeast, Role, useMe } from "../identity";
import { href } from "../router";
import { buildSchedule, type CaptureDraft, type CaptureKind, captureFieldPath, capturePath,
         formFields, newCapture, newScheduleDraft, type ScheduleDraft } from "../schedule_form";
import { describeCron, describePlan, missedRunPolicyText, runOutcome } from "../schedule_text";
import { Badge, ErrorBox, formatTime, usePoll } from "../ui";
import { Check, ConfirmButton, Field, ImageFormatOptions, TableWrap } from "./form_parts";

const kRunsPerPage = 20;

// Pipeline steps a schedule can run after its captures (step_table.cc).
const kSteps = ["decode", "rectify", "response", "hdr", "tonemap", "sl_groundtruth", "stereo",
                "fusion", "evaluate", "export", "report"];

function When({ schedule }: { schedule: Schedule }) {
  const words = describeCron(schedule.cron);
  return (
    <>
      <code>{schedule.cron}</code>
      {words && <div>{words}</div>}
      <div class="muted">{schedule.timeZone || "UTC"}; {missedRunPolicyText(schedule.missedRunPolicy)}</div>
    </>
  );
}

function RunRow({ run }: { run: ScheduleRun }) {
  const outcome = runOutcome(run.outcome);
  return (
    <tr>
      <td>{formatTime(run.dueTime)}</td>
      <td>{formatTime(run.startTime)}</td>
      <td><Badge tone={outcome.tone}>{outcome.word}</Badge></td>
      <td>{run.session ? <a href={href("sessions", run.session)}>{run.session}</a> : "–"}</td>
      <td>
        {run.jobIds.length === 0 ? "–" : run.jobIds.map((id, i) => (
          <span key={String(id)}>{i > 0 && ", "}<a href={href("jobs", id)}>#{String(id)}</a></span>
        ))}
      </td>
      <td>{run.causedBy || "–"}</td>
      <td>{run.reason || "–"}</td>
    </tr>
  );
}

const runKey = (run: ScheduleRun) => String(run.dueTime?.seconds ?? run.session);

// A schedule's runs, newest first: the first page kept up to date, older
// pages on request.
function Runs({ name }: { name: string }) {
  const first = usePoll(() => api.schedules.listRuns({ name, page: { pageSize: kRunsPerPage } }),
                        10000, [name]);
  const [older, setOlder] = useState<ScheduleRun[]>([]);
  const [token, setToken] = useState<string | undefined>(undefined);
  const [error, setError] = useState<string | undefined>(undefined);
  const next = token ?? first.value?.nextPageToken ?? "";
  const more = async () => {
    try {
      const page = await api.schedules.listRuns({ name, page: { pageSize: kRunsPerPage, pageToken: next } });
      setOlder((runs) => [...runs, ...page.runs]);
      setToken(page.nextPageToken);
      setError(undefined);
    } catch (e) {
      setError(errorMessage(e));
    }
  };
  // Runs that came due since push the first page's last ones into the
  // older pages: each run once.
  const newest = first.value?.runs ?? [];
  const seen = new Set(newest.map(runKey));
  const runs = [...newest, ...older.filter((r) => !seen.has(runKey(r)))];
  return (
    <div class="runs">
      <ErrorBox error={first.error ?? error} />
      {first.value && runs.length === 0 && <p class="muted">It has not run yet.</p>}
      {runs.length > 0 && (
        <TableWrap label={`Table of runs of ${name}`}>
          <table>
            <caption class="visually-hidden">Runs of schedule {name}, newest first</caption>
            <thead>
              <tr><th scope="col">Due</th><th scope="col">Started</th><th scope="col">Outcome</th>
                <th scope="col">Session</th><th scope="col">Jobs</th><th scope="col">On behalf of</th>
                <th scope="col">Reason</th></tr>
            </thead>
            <tbody>{runs.map((r) => <RunRow key={runKey(r)} run={r} />)}</tbody>
          </table>
        </TableWrap>
      )}
      {next !== "" && <button type="button" class="secondary" onClick={more}>Older runs</button>}
    </div>
  );
}

function ScheduleRows({ schedule, admin, onChanged }:
                      { schedule: Schedule; admin: boolean; onChanged: () => void }) {
  const [open, setOpen] = useState(false);
  const [error, setError] = useState<string | undefined>(undefined);
  const runsId = `runs-${schedule.name}`;
  const setEnabled = async (enabled: boolean) => {
    try {
      await api.schedules.setEnabled({ name: schedule.name, enabled });
      setError(undefined);
      onChanged();
    } catch (e) {
      setError(errorMessage(e));
    }
  };
  return (
    <>
      <tr>
        <th scope="row">{schedule.name}</th>
        <td><When schedule={schedule} /></td>
        <td class="plan">
          <ul class="plain">{describePlan(schedule.plan, schedule.name).map((l) => <li key={l}>{l}</li>)}</ul>
        </td>
        <td>{schedule.enabled ? <Badge tone="ok">enabled</Badge> : <Badge tone="idle">disabled</Badge>}</td>
        <td>{schedule.enabled ? formatTime(schedule.nextDueTime) : "none while disabled"}</td>
        <td>{schedule.createdBy || "–"}<div class="muted">{formatTime(schedule.createTime)}</div></td>
        <td>
          <div class="actions">
            <button type="button" class="secondary" aria-expanded={open} aria-controls={runsId}
                    onClick={() => setOpen(!open)}>
              {open ? "Hide runs" : "Runs"}
            </button>
            {admin && (
              <button type="button" class="secondary" onClick={() => setEnabled(!schedule.enabled)}>
                {schedule.enabled ? "Disable" : "Enable"}
              </button>
            )}
            {admin && (
              <ConfirmButton label="Delete" confirmLabel="Delete it"
                             question={`Delete schedule ${schedule.name}? Its runs' sessions and jobs stay.`}
                             act={async () => { await api.schedules.delete({ name: schedule.name }); onChanged(); }} />
            )}
          </div>
          <ErrorBox error={error} />
        </td>
      </tr>
      {open && (
        <tr id={runsId} class="detail">
          <td colSpan={7}>
            <h3>Runs of {schedule.name}</h3>
            <Runs name={schedule.name} />
          </td>
        </tr>
      )}
    </>
  );
}

function CaptureEditor({ index, capture, errors, onChange, onRemove }: {
  index: number; capture: CaptureDraft; errors: FormErrors;
  onChange: (c: CaptureDraft) => void; onRemove?: () => void;
}) {
  const id = (f: string) => `new-schedule-c${index}-${f}`;
  const path = (f: string) => captureFieldPath(index, capture.kind, f);
  const text = (f: keyof CaptureDraft, field: string, label: string, help?: string) => (
    <Field id={id(field)} label={label} help={help} error={errors.fields[path(field)]}>
      {(p) => <input {...p} inputMode="decimal" value={capture[f] as string}
                     onInput={(e) => onChange({ ...capture, [f]: e.currentTarget.value })} />}
    </Field>
  );
  const stereo = capture.kind === "bracketed_stereo";
  return (
    <fieldset class="capture">
      <legend>Capture {index + 1}</legend>
      {errors.fields[capturePath(index)] &&
        <p class="field-error" role="alert">{errors.fields[capturePath(index)]}</p>}
      <div class="row">
        <Field id={id("kind")} label="Kind">
          {(p) => (
            <select {...p} value={capture.kind}
                    onChange={(e) => onChange({ ...capture, kind: e.currentTarget.value as CaptureKind })}>
              <option value="bracketed_stereo">Bracketed stereo</option>
              <option value="structured_light">Structured light</option>
            </select>
          )}
        </Field>
        {onRemove && <button type="button" class="secondary" onClick={onRemove}>Remove capture {index + 1}</button>}
      </div>
      <div class="form-grid">
        {!(stereo && capture.autoBracket) &&
          text("exposures", "exposures_s", "Exposures (s)",
               stereo ? "e.g. 1/60, 1/250; empty: the 8 defaults" : "empty: two defaults")}
        {text("views", "views", "Views", "empty: 2")}
        {text("baselineMm", "baseline_mm", "Baseline (mm)", "between views; empty: 150")}
        {text("settleS", "settle_s", "Settle (s)", "after each move")}
        {text("iso", "iso", "ISO", "empty: the camera's")}
        {text("apertureF", "aperture_f", "Aperture (f/)", "empty: the camera's")}
        {stereo && (
          <Field id={id("format")} label="Format" error={errors.fields[path("format")]}>
            {(p) => (
              <select {...p} value={String(capture.format)}
                      onChange={(e) => onChange({ ...capture, format: Number(e.currentTarget.value) })}>
                <ImageFormatOptions />
              </select>
            )}
          </Field>
        )}
      </div>
      {stereo ? (
        <div class="row">
          <Check id={id("auto")} label="Automatic bracketing (the rig chooses the exposures)"
                 checked={capture.autoBracket} error={errors.fields[path("auto_bracket")]}
                 onChange={(v) => onChange({ ...capture, autoBracket: v })} />
          <Check id={id("ambient")} label="Skip the ambient frame" checked={capture.skipAmbient}
                 error={errors.fields[path("skip_ambient")]}
                 onChange={(v) => onChange({ ...capture, skipAmbient: v })} />
        </div>
      ) : (
        <div class="row">
          <Check id={id("probe")} label="Probe the projector's latency first"
                 checked={capture.projectorProbe} error={errors.fields[path("projector_probe")]}
                 onChange={(v) => onChange({ ...capture, projectorProbe: v })} />
          <Check id={id("round")} label="Round exposures to whole display refresh periods"
                 checked={capture.roundExposures}
                 error={errors.fields[path("round_exposures_to_refresh")]}
                 onChange={(v) => onChange({ ...capture, roundExposures: v })} />
        </div>
      )}
    </fieldset>
  );
}

// onDone: with what to tell the admin once created, or undefined when cancelled.
function NewSchedule({ onDone }: { onDone: (notice?: string) => void }) {
  const [draft, setDraft] = useState<ScheduleDraft>(
    () => newScheduleDraft(Intl.DateTimeFormat().resolvedOptions().timeZone ?? ""));
  const [errors, setErrors] = useState<FormErrors>(kNoErrors);
  const [busy, setBusy] = useState(false);
  const set = (change: Partial<ScheduleDraft>) => setDraft({ ...draft, ...change });
  const setCapture = (i: number, c: CaptureDraft) =>
    set({ captures: draft.captures.map((old, j) => (j === i ? c : old)) });
  const words = describeCron(draft.cron);

  const submit = async (e: Event) => {
    e.preventDefault();
    const built = buildSchedule(draft);
    if (built.errors) {
      setErrors({ fields: built.errors });
      return;
    }
    setBusy(true);
    try {
      const made = await api.schedules.create({ schedule: built.schedule });
      setErrors(kNoErrors);
      // The daemon enables a new schedule; the form can ask for it disabled.
      let notice = `Created schedule ${made.name}.`;
      if (!draft.enabled) {
        try {
          await api.schedules.setEnabled({ name: made.name, enabled: false });
          notice = `Created schedule ${made.name}, disabled.`;
        } catch (err) {
          notice = `Created schedule ${made.name}, but it is enabled: disabling it failed: ${errorMessage(err)}`;
        }
      }
      onDone(notice);
    } catch (err) {
      setErrors(placeError(errorMessage(err), formFields(draft)));
    } finally {
      setBusy(false);
    }
  };
  const f = errors.fields;
  return (
    <section class="card" aria-labelledby="new-schedule-title">
      <h2 id="new-schedule-title">New schedule</h2>
      <form onSubmit={submit} noValidate>
        {errors.top && <p class="error" role="alert"><strong>Refused:</strong> {errors.top}</p>}
        {Object.keys(f).length > 0 && !errors.top &&
          <p class="error" role="alert">The daemon refused it: see the marked field.</p>}
        <div class="form-grid">
          <Field id="new-schedule-name" label="Name" error={f["schedule.name"]}
                 help="letters, digits, '-' and '_'">
            {(p) => <input {...p} value={draft.name} required onInput={(e) => set({ name: e.currentTarget.value })} />}
          </Field>
          <Field id="new-schedule-cron" label="When (cron)" error={f["schedule.cron"]}
                 help={<>minute hour day-of-month month day-of-week, or @daily…
                   {words && <> — <strong>{words}</strong></>}</>}>
            {(p) => <input {...p} class="mono" value={draft.cron} required
                           onInput={(e) => set({ cron: e.currentTarget.value })} />}
          </Field>
          <Field id="new-schedule-tz" label="Time zone" error={f["schedule.time_zone"]}
                 help="IANA name, e.g. Europe/Berlin; empty: UTC">
            {(p) => <input {...p} value={draft.timeZone} list="new-schedule-zones"
                           onInput={(e) => set({ timeZone: e.currentTarget.value })} />}
          </Field>
          <Field id="new-schedule-missed" label="A run missed while the daemon was down"
                 error={f["schedule.missed_run_policy"]}>
            {(p) => (
              <select {...p} value={String(draft.missedRunPolicy)}
                      onChange={(e) => set({ missedRunPolicy: Number(e.currentTarget.value) })}>
                <option value={String(MissedRunPolicy.RUN_ONCE_ON_START)}>runs once at start</option>
                <option value={String(MissedRunPolicy.SKIP)}>is skipped</option>
              </select>
            )}
          </Field>
          <Field id="new-schedule-session" label="Session name" error={f["plan.session_pattern"]}
                 help={<>{"{date}"} and {"{time}"} expand; empty: <code>{draft.name || "NAME"}-{"{date}-{time}"}</code></>}>
            {(p) => <input {...p} value={draft.sessionPattern} placeholder="nightly-{date}"
                           onInput={(e) => set({ sessionPattern: e.currentTarget.value })} />}
          </Field>
        </div>
        <datalist id="new-schedule-zones">
          {Intl.supportedValuesOf("timeZone").map((z) => <option key={z} value={z} />)}
        </datalist>
        <Check id="new-schedule-enabled" label="Enabled (runs when due)" checked={draft.enabled}
               error={f["schedule.enabled"]} onChange={(v) => set({ enabled: v })} />
        <h3>Captures</h3>
        {f["plan.captures"] && <p class="field-error" role="alert">{f["plan.captures"]}</p>}
        {draft.captures.map((c, i) => (
          <CaptureEditor key={i} index={i} capture={c} errors={errors}
                         onChange={(next) => setCapture(i, next)}
                         onRemove={draft.captures.length > 1
                           ? () => set({ captures: draft.captures.filter((_, j) => j !== i) }) : undefined} />
        ))}
        <div class="row">
          <button type="button" class="secondary"
                  onClick={() => set({ captures: [...draft.captures, newCapture("bracketed_stereo")] })}>
            Add a capture
          </button>
        </div>
        <fieldset class="steps" aria-describedby={f["plan.processing_steps"] ? "new-schedule-steps-error" : undefined}>
          <legend>Processing after the captures</legend>
          <p class="help">None ticked: no processing. The steps a ticked step needs are added.</p>
          <div class="row">
            {kSteps.map((step) => (
              <Check key={step} id={`new-schedule-step-${step}`} label={step}
                     checked={draft.processingSteps.includes(step)}
                     onChange={(v) => set({ processingSteps: v
                       ? kSteps.filter((s) => s === step || draft.processingSteps.includes(s))
                       : draft.processingSteps.filter((s) => s !== step) })} />
            ))}
          </div>
          {f["plan.processing_steps"] &&
            <p class="field-error" id="new-schedule-steps-error">{f["plan.processing_steps"]}</p>}
        </fieldset>
        <div class="row">
          <button type="submit" disabled={busy}>Create schedule</button>
          <button type="button" class="secondary" onClick={() => onDone()}>Cancel</button>
        </div>
      </form>
    </section>
  );
}

export function SchedulesPage() {
  const me = useMe();
  const admin = atLeast(me, Role.ADMIN);
  const list = usePoll(() => api.schedules.list({ page: { pageSize: 1000 } }), 10000);
  const [creating, setCreating] = useState(false);
  const [notice, setNotice] = useState<string | undefined>(undefined);
  const schedules = list.value?.schedules ?? [];
  return (
    <div class="schedules-page">
      <div class="row page-head">
        <h1 id="schedules-title">Schedules</h1>
        {admin && !creating &&
          <button type="button" onClick={() => { setNotice(undefined); setCreating(true); }}>New schedule</button>}
      </div>
      <p role="status" class={notice ? "notice" : "visually-hidden"}>{notice}</p>
      {!admin && <p class="help">Creating, enabling and deleting schedules needs the admin role.</p>}
      {creating && <NewSchedule onDone={(done) => { setCreating(false); setNotice(done); if (done) list.reload(); }} />}
      <ErrorBox error={list.error} />
      {list.value === undefined && !list.error && <p class="muted">Loading…</p>}
      {list.value && schedules.length === 0 && <p>No schedules yet.</p>}
      {schedules.length > 0 && (
        <TableWrap label="Table of schedules">
          <table class="schedules">
            <caption class="visually-hidden">Schedules</caption>
            <thead>
              <tr><th scope="col">Name</th><th scope="col">When</th><th scope="col">Plan</th>
                <th scope="col">State</th><th scope="col">Next run <span class="muted">(your time)</span></th><th scope="col">Created by</th>
                <th scope="col">{admin ? "Actions" : "Runs"}</th></tr>
            </thead>
            <tbody>
              {schedules.map((s) => <ScheduleRows key={s.name} schedule={s} admin={admin} onChanged={list.reload} />)}
            </tbody>
          </table>
        </TableWrap>
      )}
    </div>
  );
}
