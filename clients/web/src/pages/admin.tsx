// SPDX-License-Identifier: GPL-3.0-or-later
//
// Administration (every call needs role admin; the navigation shows the
// page to admins only): API keys, with a new key shown once; webhooks with
// their deliveries, a new hook's signing secret shown once; the audit log
// with the filters ListAuditLog takes, page by page.
import type { Timestamp } from "@bufbuild/protobuf/wkt";
import { useState } from "preact/hooks";
import { api, errorMessage } from "../api";
import { Admin, type ApiKey, type AuditEntry, type Webhook,
         type WebhookDelivery } from "../../gen/hdrstereo/v1/admin_pb";
import { Hardware } from "../../gen/hdrstereo/v1/hardware_pb";
import { Jobs } from "../../gen/hdrstereo/v1/jobs_pb";
import { Schedules } from "../../gen/hdrstereo/v1/schedules_pb";
import { Server } from "../../gen/hdrstereo/v1/server_pb";
import { Sessions } from "../../gen/hdrstereo/v1/sessions_pb";
import { callOutcome, deliveryState, keyState, kWebhookEvents, localTimeToTimestamp,
         ttlSeconds, type TtlUnit, webhookEventFilter } from "../admin_text";
import { type FormErrors, kNoErrors, placeError } from "../field_errors";
import { Role, roleName } from "../identity";
import { Badge, ErrorBox, formatTime, usePoll } from "../ui";
import { Check, ConfirmButton, Field, ShownOnce, TableWrap } from "./form_parts";

const kPageSize = 50;

// Every method's full name, for the audit filter's suggestions.
const kMethods = [Server, Hardware, Jobs, Sessions, Schedules, Admin]
  .flatMap((s) => s.methods.map((m) => `/${s.typeName}/${m.name}`));

// ---------------------------------------------------------------- API keys

function NewKeyForm({ onCreated }: { onCreated: (user: string, role: Role, id: string, key: string) => void }) {
  const [user, setUser] = useState("");
  const [role, setRole] = useState(Role.VIEWER);
  const [amount, setAmount] = useState("30");
  const [unit, setUnit] = useState<TtlUnit>("days");
  const [note, setNote] = useState("");
  const [errors, setErrors] = useState<FormErrors>(kNoErrors);
  const [busy, setBusy] = useState(false);
  const submit = async (e: Event) => {
    e.preventDefault();
    let ttlS: bigint;
    try {
      ttlS = ttlSeconds(amount, unit);
    } catch (err) {
      setErrors({ fields: { ttl_s: errorMessage(err) } });
      return;
    }
    setBusy(true);
    try {
      const made = await api.admin.createApiKey({ user: user.trim(), role, ttlS, note });
      setErrors(kNoErrors);
      setUser("");
      setNote("");
      onCreated(made.key?.user ?? user, made.key?.role ?? role, made.key?.id ?? "", made.apiKey);
    } catch (err) {
      setErrors(placeError(errorMessage(err), ["user", "role", "ttl_s", "note"]));
    } finally {
      setBusy(false);
    }
  };
  const f = errors.fields;
  return (
    <form onSubmit={submit} aria-labelledby="new-key-title" noValidate>
      <h3 id="new-key-title">New API key</h3>
      {errors.top && <p class="error" role="alert"><strong>Refused:</strong> {errors.top}</p>}
      <div class="form-grid">
        <Field id="new-key-user" label="User" error={f.user} help="a user in [auth.users] of the daemon's config">
          {(p) => <input {...p} value={user} required autoComplete="off" onInput={(e) => setUser(e.currentTarget.value)} />}
        </Field>
        <Field id="new-key-role" label="Role" error={f.role} help="at most the user's role">
          {(p) => (
            <select {...p} value={String(role)} onChange={(e) => setRole(Number(e.currentTarget.value))}>
              <option value={String(Role.VIEWER)}>viewer</option>
              <option value={String(Role.OPERATOR)}>operator</option>
              <option value={String(Role.ADMIN)}>admin</option>
            </select>
          )}
        </Field>
        <Field id="new-key-ttl" label="Expires after" error={f.ttl_s} help="at most 366 days">
          {(p) => (
            <div class="row">
              <input {...p} class="short" inputMode="numeric" value={amount}
                     onInput={(e) => setAmount(e.currentTarget.value)} />
              <select aria-label="Unit" value={unit} onChange={(e) => setUnit(e.currentTarget.value as TtlUnit)}>
                <option value="days">days</option>
                <option value="hours">hours</option>
              </select>
            </div>
          )}
        </Field>
        <Field id="new-key-note" label="Note" error={f.note} help="what it is for, e.g. the notebook on rig-pc">
          {(p) => <input {...p} value={note} onInput={(e) => setNote(e.currentTarget.value)} />}
        </Field>
      </div>
      <button type="submit" disabled={busy || user.trim() === ""}>Create key</button>
    </form>
  );
}

function KeyRow({ apiKey, onRevoked }: { apiKey: ApiKey; onRevoked: () => void }) {
  const state = keyState(apiKey, Date.now());
  return (
    <tr>
      <th scope="row" class="mono">{apiKey.id}</th>
      <td>{apiKey.user}</td>
      <td>{roleName(apiKey.role)}</td>
      <td>{apiKey.note || "–"}</td>
      <td>{formatTime(apiKey.createTime)}<div class="muted">by {apiKey.createdBy || "–"}</div></td>
      <td>{formatTime(apiKey.expireTime)}</td>
      <td>{apiKey.lastUsedTime ? formatTime(apiKey.lastUsedTime) : "never"}</td>
      <td>
        <Badge tone={state.tone}>{state.word}</Badge>
        {apiKey.revokeTime && <div class="muted">{formatTime(apiKey.revokeTime)}</div>}
      </td>
      <td>
        {state.word === "active" && (
          <ConfirmButton label="Revoke" confirmLabel="Revoke it"
                         question={`Revoke key ${apiKey.id} of ${apiKey.user}? Its sessions end at their next request.`}
                         act={async () => { await api.admin.revokeApiKey({ id: apiKey.id }); onRevoked(); }} />
        )}
      </td>
    </tr>
  );
}

function ApiKeys() {
  const [includeRevoked, setIncludeRevoked] = useState(false);
  const [user, setUser] = useState("");
  const [pageToken, setPageToken] = useState<string[]>([""]);  // tokens of the pages shown so far
  const token = pageToken[pageToken.length - 1];
  const list = usePoll(() => api.admin.listApiKeys({
    user: user.trim(), includeRevoked, page: { pageSize: kPageSize, pageToken: token } }),
    0, [includeRevoked, user, token]);
  const [shown, setShown] = useState<{ title: string; secret: string; about: string } | undefined>(undefined);
  return (
    <section class="card" aria-labelledby="keys-title">
      <h2 id="keys-title">API keys</h2>
      <NewKeyForm onCreated={(u, role, id, key) => {
        setShown({ title: `New API key for ${u}`, secret: key,
                   about: `Key ${id}, role ${roleName(role)}. Give it to ${u}; it signs in to this console and is sent as "authorization: Bearer <key>" by scripts. Keep it in a file only its owner can read (chmod 600).` });
        list.reload();
      }} />
      {shown && (
        <ShownOnce title={shown.title} label="API key" secret={shown.secret} onClose={() => setShown(undefined)}>
          <p>{shown.about}</p>
        </ShownOnce>
      )}
      <h3>Keys</h3>
      <div class="row filters">
        <Check id="keys-revoked" label="Show revoked and expired keys" checked={includeRevoked}
               onChange={(v) => { setIncludeRevoked(v); setPageToken([""]); }} />
        <label for="keys-user">User</label>
        <input id="keys-user" value={user} placeholder="every user"
               onChange={(e) => { setUser(e.currentTarget.value); setPageToken([""]); }} />
      </div>
      <ErrorBox error={list.error} />
      {list.value && list.value.keys.length === 0 && <p>No keys.</p>}
      {list.value && list.value.keys.length > 0 && (
        <TableWrap label="Table of API keys">
          <table>
            <caption class="visually-hidden">API keys (the secret part is never shown)</caption>
            <thead>
              <tr><th scope="col">Key id</th><th scope="col">User</th><th scope="col">Role</th>
                <th scope="col">Note</th><th scope="col">Created</th><th scope="col">Expires</th>
                <th scope="col">Last used</th><th scope="col">State</th><th scope="col">Actions</th></tr>
            </thead>
            <tbody>{list.value.keys.map((k) => <KeyRow key={k.id} apiKey={k} onRevoked={list.reload} />)}</tbody>
          </table>
        </TableWrap>
      )}
      <Pager label="Pages of API keys" tokens={pageToken} next={list.value?.nextPageToken} onChange={setPageToken} />
    </section>
  );
}

// Previous/next through token-paged results: `tokens` holds the token of
// each page shown so far (the first is "").
function Pager({ label, tokens, next, onChange }:
               { label: string; tokens: string[]; next?: string; onChange: (tokens: string[]) => void }) {
  if (tokens.length === 1 && !next) return null;
  return (
    <nav class="row pager" aria-label={label}>
      <button type="button" class="secondary" disabled={tokens.length === 1}
              onClick={() => onChange(tokens.slice(0, -1))}>Previous page</button>
      <span>Page {tokens.length}</span>
      <button type="button" class="secondary" disabled={!next}
              onClick={() => next && onChange([...tokens, next])}>Next page</button>
    </nav>
  );
}

// ---------------------------------------------------------------- Webhooks

function NewWebhookForm({ onCreated }: { onCreated: (hook: Webhook | undefined, secret: string) => void }) {
  const [url, setUrl] = useState("");
  const [events, setEvents] = useState<string[]>([]);
  const [note, setNote] = useState("");
  const [errors, setErrors] = useState<FormErrors>(kNoErrors);
  const [busy, setBusy] = useState(false);
  const submit = async (e: Event) => {
    e.preventDefault();
    setBusy(true);
    try {
      const made = await api.admin.createWebhook({ url: url.trim(), events: webhookEventFilter(events), note });
      setErrors(kNoErrors);
      setUrl("");
      setEvents([]);
      setNote("");
      onCreated(made.webhook, made.secret);
    } catch (err) {
      setErrors(placeError(errorMessage(err), ["url", "events", "note"]));
    } finally {
      setBusy(false);
    }
  };
  const f = errors.fields;
  return (
    <form onSubmit={submit} aria-labelledby="new-hook-title" noValidate>
      <h3 id="new-hook-title">New webhook</h3>
      {errors.top && <p class="error" role="alert"><strong>Refused:</strong> {errors.top}</p>}
      <div class="form-grid">
        <Field id="new-hook-url" label="URL" wide error={f.url} help="http:// or https://; the daemon POSTs JSON events to it">
          {(p) => <input {...p} type="url" value={url} required
                         onInput={(e) => setUrl(e.currentTarget.value)} />}
        </Field>
        <Field id="new-hook-note" label="Note" error={f.note}>
          {(p) => <input {...p} value={note} onInput={(e) => setNote(e.currentTarget.value)} />}
        </Field>
      </div>
      <fieldset aria-describedby={f.events ? "new-hook-events-error" : "new-hook-events-help"}>
        <legend>Events</legend>
        <p class="help" id="new-hook-events-help">None ticked: every event. A family (*) covers its members.</p>
        <div class="row">
          {kWebhookEvents.map((ev) => (
            <Check key={ev} id={`new-hook-ev-${ev.replace(/[.*]/g, "_")}`} label={ev}
                   checked={events.includes(ev)}
                   onChange={(v) => setEvents(v ? [...events, ev] : events.filter((x) => x !== ev))} />
          ))}
        </div>
        {f.events && <p class="field-error" id="new-hook-events-error">{f.events}</p>}
      </fieldset>
      <button type="submit" disabled={busy || url.trim() === ""}>Create webhook</button>
    </form>
  );
}

function Deliveries({ hook }: { hook: bigint }) {
  const [tokens, setTokens] = useState<string[]>([""]);
  const token = tokens[tokens.length - 1];
  const list = usePoll(() => api.admin.listWebhookDeliveries({
    webhookId: hook, page: { pageSize: 20, pageToken: token } }), token === "" ? 10000 : 0, [hook, token]);
  const rows: WebhookDelivery[] = list.value?.deliveries ?? [];
  return (
    <div>
      <ErrorBox error={list.error} />
      {list.value && rows.length === 0 && <p class="muted">No deliveries yet.</p>}
      {rows.length > 0 && (
        <TableWrap label={`Table of deliveries of webhook ${hook}`}>
          <table>
            <caption class="visually-hidden">Deliveries of webhook {String(hook)}, newest first</caption>
            <thead>
              <tr><th scope="col">Time</th><th scope="col">Event</th><th scope="col">Attempt</th>
                <th scope="col">HTTP status</th><th scope="col" class="num">Took</th>
                <th scope="col">Event state</th><th scope="col">Error</th></tr>
            </thead>
            <tbody>
              {rows.map((d) => {
                const state = deliveryState(d.eventState);
                return (
                  <tr key={String(d.id)}>
                    <td>{formatTime(d.time)}</td>
                    <td>{d.eventType}<div class="muted mono long">{d.eventId}</div></td>
                    <td>{d.attempt}</td>
                    <td>{d.httpStatus === 0 ? "no response" : d.httpStatus}</td>
                    <td class="num">{String(d.durationMs)} ms</td>
                    <td><Badge tone={state.tone}>{state.word}</Badge></td>
                    <td>{d.error || "–"}</td>
                  </tr>
                );
              })}
            </tbody>
          </table>
        </TableWrap>
      )}
      <Pager label={`Pages of deliveries of webhook ${hook}`} tokens={tokens} next={list.value?.nextPageToken} onChange={setTokens} />
    </div>
  );
}

function HookRows({ hook, onDeleted }: { hook: Webhook; onDeleted: () => void }) {
  const [open, setOpen] = useState(false);
  const id = `deliveries-${hook.id}`;
  const last = hook.lastAttemptTime
    ? (hook.lastError ? <Badge tone="bad">failed</Badge> : <Badge tone="ok">delivered</Badge>)
    : <Badge tone="idle">no attempt yet</Badge>;
  return (
    <>
      <tr>
        <th scope="row">{String(hook.id)}</th>
        <td class="long">{hook.url}</td>
        <td class="long">{hook.events.length === 0 ? "every event" : hook.events.join(", ")}</td>
        <td>{hook.note || "–"}</td>
        <td>{hook.createdBy}<div class="muted">{formatTime(hook.createTime)}</div></td>
        <td class="num counts">{String(hook.pending)} pending<br />{String(hook.delivered)} delivered<br />
          {String(hook.abandoned)} abandoned</td>
        <td>
          {last}
          {hook.lastAttemptTime && <div class="muted">{formatTime(hook.lastAttemptTime)}
            {hook.lastHttpStatus ? `, HTTP ${hook.lastHttpStatus}` : ", no response"}</div>}
          {hook.lastError && <div>{hook.lastError}</div>}
        </td>
        <td>
          <div class="actions">
            <button type="button" class="secondary" aria-expanded={open} aria-controls={id}
                    onClick={() => setOpen(!open)}>{open ? "Hide deliveries" : "Deliveries"}</button>
            <ConfirmButton label="Delete" confirmLabel="Delete it"
                           question={`Delete webhook ${hook.id}? Its queued events and delivery history go too.`}
                           act={async () => { await api.admin.deleteWebhook({ id: hook.id }); onDeleted(); }} />
          </div>
        </td>
      </tr>
      {open && (
        <tr id={id} class="detail">
          <td colSpan={8}>
            <h3>Deliveries to {hook.url}</h3>
            <Deliveries hook={hook.id} />
          </td>
        </tr>
      )}
    </>
  );
}

function Webhooks() {
  const list = usePoll(() => api.admin.listWebhooks({}), 15000);
  const [shown, setShown] = useState<{ secret: string; about: string } | undefined>(undefined);
  const hooks = list.value?.webhooks ?? [];
  return (
    <section class="card" aria-labelledby="hooks-title">
      <h2 id="hooks-title">Webhooks</h2>
      <NewWebhookForm onCreated={(hook, secret) => {
        if (secret) {
          setShown({ secret, about: `Webhook ${hook?.id ?? ""} to ${hook?.url ?? ""}. Its receiver checks the X-Hdrstereo-Signature header (HMAC-SHA256) with this secret.` });
        }
        list.reload();
      }} />
      {shown && (
        <ShownOnce title="The new webhook's signing secret" label="Signing secret" secret={shown.secret}
                   onClose={() => setShown(undefined)}>
          <p>{shown.about}</p>
        </ShownOnce>
      )}
      <h3>Hooks</h3>
      <ErrorBox error={list.error} />
      {list.value && hooks.length === 0 && <p>No webhooks.</p>}
      {hooks.length > 0 && (
        <TableWrap label="Table of webhooks">
          <table>
            <caption class="visually-hidden">Webhooks</caption>
            <thead>
              <tr><th scope="col">Id</th><th scope="col">URL</th><th scope="col">Events</th>
                <th scope="col">Note</th><th scope="col">Created by</th><th scope="col" class="num">Events so far</th>
                <th scope="col">Last attempt</th><th scope="col">Actions</th></tr>
            </thead>
            <tbody>{hooks.map((h) => <HookRows key={String(h.id)} hook={h} onDeleted={list.reload} />)}</tbody>
          </table>
        </TableWrap>
      )}
    </section>
  );
}

// ---------------------------------------------------------------- Audit log

interface AuditFilter {
  principal: string;
  method: string;
  from: string;   // datetime-local values
  until: string;
}

const kNoFilter: AuditFilter = { principal: "", method: "", from: "", until: "" };

// Long machine words ("ipv4:127.0.0.1:5000", "/hdrstereo.v1.Jobs/Cancel")
// break only after ':' or '/', not inside a number or a name.
function Breakable({ text }: { text: string }) {
  const parts = text.split(/(?<=[:/])/);
  return <>{parts.map((p, i) => <span key={i}>{p}{i < parts.length - 1 && <wbr />}</span>)}</>;
}

function AuditRow({ entry }: { entry: AuditEntry }) {
  const outcome = callOutcome(entry.statusCode);
  return (
    <tr>
      <td>{formatTime(entry.time)}</td>
      <td>{entry.principal || <span class="muted">unidentified</span>}
        {entry.principal && <div class="muted">{roleName(entry.role)}</div>}
        {entry.authMethod && <div class="muted mono"><Breakable text={entry.authMethod} /></div>}</td>
      <td>{entry.transport || "–"}
        <div class="mono">{entry.peer ? <Breakable text={entry.peer} /> : "no address"}</div></td>
      <td><span class="mono" title={entry.method}>
        <Breakable text={entry.method.replace(/^\/hdrstereo\.v1\./, "")} /></span>
        {entry.subject && <div class="muted">{entry.subject}</div>}</td>
      <td><Badge tone={outcome.tone}>{outcome.word}</Badge></td>
      <td>{entry.message || "–"}</td>
    </tr>
  );
}

function AuditLog() {
  const [draft, setDraft] = useState<AuditFilter>(kNoFilter);
  const [filter, setFilter] = useState<{ principal: string; method: string; startTime?: Timestamp; endTime?: Timestamp }>({ principal: "", method: "" });
  const [tokens, setTokens] = useState<string[]>([""]);
  const [errors, setErrors] = useState<FormErrors>(kNoErrors);
  const token = tokens[tokens.length - 1];
  const list = usePoll(async () => {
    try {
      const page = await api.admin.listAuditLog({ ...filter, page: { pageSize: kPageSize, pageToken: token } });
      setErrors(kNoErrors);
      return page;
    } catch (e) {
      setErrors(placeError(errorMessage(e), ["principal", "method", "start_time", "end_time"]));
      throw e;
    }
  }, 0, [filter, token]);
  const apply = (e: Event) => {
    e.preventDefault();
    const fields: Record<string, string> = {};
    const time = (value: string, path: string) => {
      try {
        return localTimeToTimestamp(value);
      } catch (err) {
        fields[path] = errorMessage(err);
        return undefined;
      }
    };
    const startTime = time(draft.from, "start_time");
    const endTime = time(draft.until, "end_time");
    if (Object.keys(fields).length > 0) {
      setErrors({ fields });
      return;
    }
    setErrors(kNoErrors);
    setTokens([""]);
    setFilter({ principal: draft.principal.trim(), method: draft.method.trim(), startTime, endTime });
  };
  const f = errors.fields;
  const entries = list.value?.entries ?? [];
  return (
    <section class="card" aria-labelledby="audit-title">
      <h2 id="audit-title">Audit log</h2>
      <p class="help">Every call that changed something, and every call refused for credentials, role or the
        rig lock; newest first.</p>
      <form onSubmit={apply} class="audit-filter" aria-label="Audit log filter" noValidate>
        {errors.top && <p class="error" role="alert"><strong>Refused:</strong> {errors.top}</p>}
        <div class="form-grid">
          <Field id="audit-principal" label="Principal" error={f.principal} help="empty: everyone">
            {(p) => <input {...p} value={draft.principal} onInput={(e) => setDraft({ ...draft, principal: e.currentTarget.value })} />}
          </Field>
          <Field id="audit-method" label="Method contains" error={f.method} help="e.g. Jobs/ or Admin/CreateApiKey">
            {(p) => <input {...p} value={draft.method} list="audit-methods"
                           onInput={(e) => setDraft({ ...draft, method: e.currentTarget.value })} />}
          </Field>
          <Field id="audit-from" label="From" error={f.start_time} help="your local time; empty: the beginning">
            {(p) => <input {...p} type="datetime-local" value={draft.from}
                           onInput={(e) => setDraft({ ...draft, from: e.currentTarget.value })} />}
          </Field>
          <Field id="audit-until" label="Until" error={f.end_time} help="empty: now">
            {(p) => <input {...p} type="datetime-local" value={draft.until}
                           onInput={(e) => setDraft({ ...draft, until: e.currentTarget.value })} />}
          </Field>
        </div>
        <datalist id="audit-methods">{kMethods.map((m) => <option key={m} value={m} />)}</datalist>
        <div class="row">
          <button type="submit">Show</button>
          <button type="button" class="secondary"
                  onClick={() => { setDraft(kNoFilter); setErrors(kNoErrors); setTokens([""]); setFilter({ principal: "", method: "" }); }}>
            Clear filters
          </button>
          <button type="button" class="secondary" onClick={list.reload}>Refresh</button>
        </div>
      </form>
      {!errors.top && Object.keys(f).length === 0 && <ErrorBox error={list.error} />}
      {list.value && entries.length === 0 && <p>No entries match.</p>}
      {entries.length > 0 && (
        <TableWrap label="Table of audit log entries">
          <table class="audit">
            <caption class="visually-hidden">Audit log entries, newest first</caption>
            <thead>
              <tr><th scope="col">Time</th><th scope="col">Principal</th>
                <th scope="col">Transport, peer</th><th scope="col">Method</th><th scope="col">Outcome</th>
                <th scope="col">Message</th></tr>
            </thead>
            <tbody>{entries.map((e) => <AuditRow key={String(e.id)} entry={e} />)}</tbody>
          </table>
        </TableWrap>
      )}
      <Pager label="Pages of the audit log" tokens={tokens} next={list.value?.nextPageToken} onChange={setTokens} />
    </section>
  );
}

export function AdminPage() {
  return (
    <div class="admin-page">
      <h1 id="admin-title">Admin</h1>
      <ApiKeys />
      <Webhooks />
      <AuditLog />
    </div>
  );
}
