// SPDX-License-Identifier: GPL-3.0-or-later
//
// Capture: a bracketed-stereo, structured-light or calibration plan for a
// session (chosen or created here), judged by the daemon as the operator
// types (Jobs.EstimateCapture: its messages at the field they name, the
// frames, expected duration and disk need against the free space), then
// submitted; the page goes on to the job.
import type { ComponentChildren } from "preact";
import { useEffect, useMemo, useRef, useState } from "preact/hooks";
import type { CaptureEstimate } from "../../gen/hdrstereo/v1/jobs_pb";
import { api, errorMessage } from "../api";
import { buildPlan, type FormValues, kPlanFields, type PlanKind } from "../capture_plan";
import { type FieldError, fieldError } from "../plan_field_errors";
import { href } from "../router";
import { Badge, ErrorBox, formatBytes, formatDuration, Section, usePoll } from "../ui";
import { ImageFormatOptions } from "./form_parts";

const kKinds: { kind: PlanKind; title: string; help: string }[] = [
  { kind: "bracketed_stereo", title: "Bracketed stereo",
    help: "A bracket of exposures at each view, the stage moving by the baseline between views." },
  { kind: "structured_light", title: "Structured light",
    help: "Gray-code patterns and their inverses, white and black, at each exposure and view." },
  { kind: "calibration", title: "Calibration",
    help: "Checkerboard poses: the job waits before each pose for you to place the board, then you continue it." },
];

const kNewSession = "\u0000new";

// The form's state shared by its fields: values, and the messages that
// name each field.
interface FormContext {
  values: FormValues;
  set: (path: string, value: string | boolean) => void;
  errors: Map<string, string[]>;
}

function fieldId(path: string): string {
  return `f-${path.replace(/[^a-z0-9]+/gi, "-")}`;
}

function FieldMessages({ path, form }: { path: string; form: FormContext }) {
  const messages = form.errors.get(path);
  if (!messages) return null;
  return (
    <div id={`${fieldId(path)}-error`}>
      {messages.map((m) => <p key={m} class="field-error">{m}</p>)}
    </div>
  );
}

function describedBy(path: string, form: FormContext, help?: string): string | undefined {
  const ids = [help ? `${fieldId(path)}-help` : "", form.errors.has(path) ? `${fieldId(path)}-error` : ""]
    .filter((s) => s !== "");
  return ids.length > 0 ? ids.join(" ") : undefined;
}

function TextField({ path, label, help, placeholder, form, wide, disabled }:
                   { path: string; label: string; help?: string; placeholder?: string; form: FormContext;
                     wide?: boolean; disabled?: boolean }) {
  const id = fieldId(path);
  const value = form.values[path];
  return (
    <div class={`field${wide ? " wide" : ""}`}>
      <label for={id}>{label}</label>
      <input id={id} name={path} type="text" inputMode="decimal" autoComplete="off"
             value={typeof value === "string" ? value : ""} placeholder={placeholder} disabled={disabled}
             onInput={(e) => form.set(path, e.currentTarget.value)}
             aria-invalid={form.errors.has(path) ? "true" : undefined}
             aria-describedby={describedBy(path, form, help)} />
      {help && <p id={`${id}-help`} class="help">{help}</p>}
      <FieldMessages path={path} form={form} />
    </div>
  );
}

function CheckField({ path, label, help, form }:
                    { path: string; label: string; help?: string; form: FormContext }) {
  const id = fieldId(path);
  return (
    <div class="field check wide">
      <div class="row">
        <input id={id} name={path} type="checkbox" checked={form.values[path] === true}
               onChange={(e) => form.set(path, e.currentTarget.checked)}
               aria-invalid={form.errors.has(path) ? "true" : undefined}
               aria-describedby={describedBy(path, form, help)} />
        <label for={id}>{label}</label>
      </div>
      {help && <p id={`${id}-help`} class="help">{help}</p>}
      <FieldMessages path={path} form={form} />
    </div>
  );
}

function Fieldset({ legend, children }: { legend: string; children: ComponentChildren }) {
  return <fieldset class="capture-fields"><legend>{legend}</legend><div class="field-grid">{children}</div></fieldset>;
}

function GeometryFields({ kind, form }: { kind: PlanKind; form: FormContext }) {
  return (
    <>
      <TextField path={`${kind}.views`} label="Views" placeholder="2" form={form}
                 help="Stage positions, 1 to 16 (left, right, …)." />
      <TextField path={`${kind}.baseline_mm`} label="Baseline (mm)" placeholder="150" form={form}
                 help="Between neighbouring views; all must fit on the stage travel." />
      <TextField path={`${kind}.settle_s`} label="Settle (s)" placeholder="0" form={form}
                 help="Wait after each stage move, 0 to 60 s." />
    </>
  );
}

function CameraFields({ kind, form }: { kind: PlanKind; form: FormContext }) {
  return (
    <>
      <TextField path={`${kind}.iso`} label="ISO" placeholder="camera's" form={form} />
      <TextField path={`${kind}.aperture_f`} label="Aperture (f/)" placeholder="camera's" form={form} />
    </>
  );
}

function StereoFields({ form }: { form: FormContext }) {
  const auto = form.values["bracketed_stereo.auto_bracket"] === true;
  const formatPath = "bracketed_stereo.format";
  return (
    <>
      <Fieldset legend="Exposures">
        <CheckField path="bracketed_stereo.auto_bracket" label="Automatic bracketing" form={form}
                    help="Meters each view with probe frames and chooses the fewest shutter speeds that cover the scene." />
        {!auto && (
          <TextField path="bracketed_stereo.exposures_s" label="Exposures (s)" wide form={form}
                     placeholder="1/15, 1/30, 1/60, 1/125, 1/250, 1/500, 1/1000, 1/2000"
                     help="Seconds or fractions, separated by commas; empty: the thesis bracket shown." />
        )}
        {auto && (
          <>
            <TextField path="bracketed_stereo.auto_bracket.min_snr" label="Least SNR per sample" placeholder="40" form={form}
                       help="10 to 1000." />
            <TextField path="bracketed_stereo.auto_bracket.max_step_stops" label="Largest step (stops)" placeholder="by format" form={form}
                       help="Between neighbouring exposures, 1/3 to 8." />
            <TextField path="bracketed_stereo.auto_bracket.exclude_emitters_above" label="Exclude emitters above (× median)" placeholder="0 (keep)" form={form}
                       help="0 covers lamps like every pixel; above 1 excludes pixels that much brighter than the view's median." />
            <TextField path="bracketed_stereo.auto_bracket.max_uncovered_fraction" label="Uncovered fraction allowed" placeholder="0" form={form}
                       help="0 to below 1." />
            <TextField path="bracketed_stereo.auto_bracket.max_exposure_s" label="Longest exposure (s)" placeholder="camera's longest" form={form} />
          </>
        )}
        <CheckField path="bracketed_stereo.skip_ambient" label="Skip the ambient frame" form={form}
                    help="By default one frame of the scene as it is is taken first." />
      </Fieldset>
      <Fieldset legend="Camera and stage">
        <CameraFields kind="bracketed_stereo" form={form} />
        <div class="field">
          <label for={fieldId(formatPath)}>Format</label>
          <select id={fieldId(formatPath)} name={formatPath}
                  value={typeof form.values[formatPath] === "string" ? form.values[formatPath] as string : "0"}
                  onChange={(e) => form.set(formatPath, e.currentTarget.value)}
                  aria-invalid={form.errors.has(formatPath) ? "true" : undefined}
                  aria-describedby={describedBy(formatPath, form)}>
            <ImageFormatOptions />
          </select>
          <FieldMessages path={formatPath} form={form} />
        </div>
        <GeometryFields kind="bracketed_stereo" form={form} />
      </Fieldset>
    </>
  );
}

function StructuredLightFields({ form }: { form: FormContext }) {
  const probe = form.values["structured_light.projector_probe"] === true;
  return (
    <>
      <Fieldset legend="Exposures">
        <TextField path="structured_light.exposures_s" label="Exposures (s)" wide form={form}
                   placeholder="1/30, 1/125" help="Seconds or fractions, separated by commas; empty: the two shown." />
        <CheckField path="structured_light.round_exposures_to_refresh" label="Round exposures to whole display refresh periods" form={form}
                    help="Needs a projector that reports its refresh rate." />
      </Fieldset>
      <Fieldset legend="Projector">
        <CheckField path="structured_light.projector_probe" label="Probe the projector's latency first" form={form}
                    help="Before the first frame, find how long a pattern takes to show (Hardware.ProbeProjector); each frame then waits that long." />
        {probe && (
          <>
            <TextField path="structured_light.projector_probe.step_s" label="Probe step (s)" placeholder="0.02" form={form}
                       help="Delay step, up to 1 s." />
            <TextField path="structured_light.projector_probe.max_delay_s" label="Longest delay (s)" placeholder="0.5" form={form}
                       help="Up to 10 s and 100 steps." />
            <TextField path="structured_light.projector_probe.exposure_s" label="Probe exposure (s)" placeholder="1/125" form={form} />
          </>
        )}
      </Fieldset>
      <Fieldset legend="Camera and stage">
        <CameraFields kind="structured_light" form={form} />
        <GeometryFields kind="structured_light" form={form} />
      </Fieldset>
    </>
  );
}

function CalibrationFields({ form }: { form: FormContext }) {
  return (
    <>
      <Fieldset legend="Poses">
        <TextField path="calibration.poses" label="Board poses" placeholder="e.g. 12" form={form}
                   help="1 to 64. The job waits before each for you to place the board and continue." />
        <TextField path="calibration.exposure_s" label="Exposure (s)" placeholder="1/60" form={form} />
        <TextField path="calibration.baseline_mm" label="Baseline (mm)" placeholder="150" form={form} />
      </Fieldset>
      <Fieldset legend="Board">
        <TextField path="calibration.board_columns" label="Inner corners along a row" placeholder="9" form={form} />
        <TextField path="calibration.board_rows" label="Inner corners down a column" placeholder="6" form={form} />
        <TextField path="calibration.board_square_mm" label="Square (mm)" placeholder="25" form={form}
                   help="Sets the scale of the calibrated baseline." />
      </Fieldset>
    </>
  );
}

// The daemon's judgement of the plan as typed: the estimate or the errors.
interface Judgement {
  estimate?: CaptureEstimate;
  errors: FieldError[];
  pending: boolean;
}

export function CapturePage() {
  const [kind, setKind] = useState<PlanKind>("bracketed_stereo");
  const [values, setValues] = useState<FormValues>({ "calibration.poses": "8" });
  const [session, setSession] = useState("");
  const [newName, setNewName] = useState("");
  const [newNote, setNewNote] = useState("");
  const [judgement, setJudgement] = useState<Judgement>({ errors: [], pending: false });
  const [submitErrors, setSubmitErrors] = useState<FieldError[]>([]);
  const [submitting, setSubmitting] = useState(false);
  const sessions = usePoll(() => api.sessions.list({ page: { pageSize: 1000 } }), 0);
  const info = usePoll(() => api.server.getInfo({}), 5000);
  const fields = useMemo(() => ["session", ...kPlanFields[kind]], [kind]);

  // Choose the newest session once the list is in.
  useEffect(() => {
    const list = sessions.value?.sessions;
    if (session !== "" || !list) return;
    const newest = [...list].sort((a, b) => Number((b.createTime?.seconds ?? 0n) - (a.createTime?.seconds ?? 0n)))[0];
    setSession(newest ? newest.name : kNewSession);
  }, [sessions.value]);

  const creating = session === kNewSession;
  const sessionName = creating ? newName.trim() : session;
  const built = useMemo(() => buildPlan(kind, values), [kind, values]);

  // Ask the daemon (debounced) whenever the plan or the session changes;
  // only the answer to the newest question is shown.
  const asked = useRef(0);
  useEffect(() => {
    const question = ++asked.current;
    setJudgement((j) => ({ ...j, pending: true }));
    const timer = setTimeout(async () => {
      let next: Judgement;
      if (built.errors.length > 0) {
        next = { errors: built.errors, pending: false };
      } else {
        try {
          // A new session's name is judged as SubmitCapture would.
          const estimate = await api.jobs.estimateCapture({ session: sessionName, plan: built.plan });
          next = { estimate, errors: [], pending: false };
        } catch (e) {
          next = { errors: [fieldError(errorMessage(e), fields)], pending: false };
        }
      }
      if (question === asked.current) setJudgement(next);
    }, 300);
    return () => clearTimeout(timer);
  }, [built, sessionName, fields]);

  const shown = [...judgement.errors, ...submitErrors];
  const errors = new Map<string, string[]>();
  for (const e of shown) {
    if (!e.field) continue;
    const list = errors.get(e.field) ?? [];
    if (!list.includes(e.message)) list.push(e.message);
    errors.set(e.field, list);
  }
  const topErrors = [...new Set(shown.filter((e) => !e.field).map((e) => e.message))];
  const form: FormContext = {
    values,
    set: (path, value) => {
      setValues((v) => ({ ...v, [path]: value }));
      setSubmitErrors([]);
    },
    errors,
  };

  const submit = async (e: Event) => {
    e.preventDefault();
    setSubmitErrors([]);
    if (built.errors.length > 0) {
      setSubmitErrors(built.errors);
      return;
    }
    setSubmitting(true);
    try {
      let name = session;
      if (creating) {
        try {
          await api.sessions.create({ name: newName.trim(), note: newNote });
        } catch (err) {
          setSubmitErrors([{ field: "session", message: errorMessage(err) }]);
          return;
        }
        name = newName.trim();
        setSession(name);
        sessions.reload();
      }
      const job = await api.jobs.submitCapture({ session: name, plan: built.plan });
      window.location.hash = href("jobs", job.id);
    } catch (err) {
      setSubmitErrors([fieldError(errorMessage(err), fields)]);
    } finally {
      setSubmitting(false);
    }
  };

  const sessionErrors = errors.get("session");
  return (
    <section class="capture-page">
      <h1>Capture</h1>
      <form onSubmit={submit} noValidate aria-describedby={topErrors.length > 0 ? "capture-errors" : undefined}>
        {topErrors.length > 0 && (
          <div id="capture-errors" class="error" role="alert">
            {topErrors.map((m) => <p key={m}><strong>Error:</strong> {m}</p>)}
          </div>
        )}
        <Section title="Session">
          <ErrorBox error={sessions.error} />
          <div class="row session-choice">
            <div class="field">
              <label for="f-session">Session</label>
              <select id="f-session" value={session} onChange={(e) => setSession(e.currentTarget.value)}
                      aria-invalid={sessionErrors && !creating ? "true" : undefined}
                      aria-describedby={sessionErrors && !creating ? "f-session-error" : undefined}>
                {(sessions.value?.sessions ?? []).map((s) => (
                  <option key={s.name} value={s.name}>{s.name}{s.note ? ` — ${s.note}` : ""}</option>
                ))}
                <option value={kNewSession}>New session…</option>
              </select>
            </div>
            {creating && (
              <>
                <div class="field">
                  <label for="f-session-name">New session's name</label>
                  <input id="f-session-name" type="text" autoComplete="off" value={newName}
                         onInput={(e) => { setNewName(e.currentTarget.value); setSubmitErrors([]); }}
                         aria-invalid={sessionErrors ? "true" : undefined}
                         aria-describedby={["f-session-name-help", sessionErrors ? "f-session-error" : ""].join(" ").trim()} />
                  <p id="f-session-name-help" class="help">Letters, digits, '-' and '_'; created when you submit.</p>
                </div>
                <div class="field wide">
                  <label for="f-session-note">Note</label>
                  <input id="f-session-note" type="text" value={newNote} onInput={(e) => setNewNote(e.currentTarget.value)} />
                </div>
              </>
            )}
          </div>
          {sessionErrors && (
            <div id="f-session-error">{sessionErrors.map((m) => <p key={m} class="field-error">{m}</p>)}</div>
          )}
        </Section>

        <Section title="Plan">
          <fieldset class="plan-kind">
            <legend>Kind of capture</legend>
            <div class="row">
              {kKinds.map((k) => (
                <label key={k.kind} class={`kind-choice${kind === k.kind ? " chosen" : ""}`}>
                  <input type="radio" name="plan-kind" value={k.kind} checked={kind === k.kind}
                         onChange={() => { setKind(k.kind); setSubmitErrors([]); }} />
                  {" "}{k.title}
                </label>
              ))}
            </div>
            <p class="help">{kKinds.find((k) => k.kind === kind)?.help}</p>
          </fieldset>
          {kind === "bracketed_stereo" && <StereoFields form={form} />}
          {kind === "structured_light" && <StructuredLightFields form={form} />}
          {kind === "calibration" && <CalibrationFields form={form} />}
        </Section>

        <Section title="Before you submit">
          <EstimateView judgement={judgement} kind={kind}
                        free={info.value?.dataRootFreeBytes} pending={info.value?.pendingCaptureBytes} />
          <ErrorBox error={info.error} />
          <div class="row">
            <button type="submit" disabled={submitting || (creating && newName.trim() === "")}>
              {submitting ? "Submitting…" : "Submit capture"}
            </button>
            <span class="muted">The job page follows it live.</span>
          </div>
        </Section>
      </form>
    </section>
  );
}

function EstimateView({ judgement, kind, free, pending }:
                      { judgement: Judgement; kind: PlanKind; free?: bigint; pending?: bigint }) {
  const estimate = judgement.errors.length === 0 ? judgement.estimate : undefined;
  if (!estimate) {
    return (
      <p class="muted estimate" aria-live="polite">
        {judgement.pending ? "Asking the daemon…"
          : judgement.errors.length > 0 ? "The daemon cannot estimate this plan: see the messages above."
          : "No estimate yet."}
      </p>
    );
  }
  const room = free !== undefined ? free - (pending ?? 0n) : undefined;
  const fits = room === undefined ? undefined : estimate.diskBytes <= room;
  return (
    <div class="estimate" aria-live="polite" aria-busy={judgement.pending ? "true" : undefined}>
      <dl class="facts">
        <dt>Frames</dt>
        <dd data-testid="estimate-frames">{String(estimate.frames)}</dd>
        <dt>Expected duration</dt>
        <dd data-testid="estimate-duration">
          about {formatDuration(estimate.durationS)}
          {kind === "calibration" && " plus the time you take to place the board at each pose"}
        </dd>
        <dt>Disk</dt>
        <dd data-testid="estimate-disk">
          {formatBytes(estimate.diskBytes)} needed (frames, processing and a margin)
          {free !== undefined && <> of {formatBytes(free)} free</>}
          {pending !== undefined && pending > 0n && <>, {formatBytes(pending)} of it promised to queued captures</>}
          {" "}
          {fits === true && <Badge tone="ok">fits</Badge>}
          {fits === false && <Badge tone="bad">does not fit</Badge>}
        </dd>
      </dl>
      {estimate.exposuresChosenAtRig && (
        <p class="help">Automatic bracketing chooses the exposures at the rig: counted here with the default bracket of 8.</p>
      )}
    </div>
  );
}
