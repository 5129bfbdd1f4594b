// SPDX-License-Identifier: GPL-3.0-or-later
//
// The console's shell: sign-in, then the pages behind a navigation bar that
// shows only what the signed-in role may use.
import { Fragment, type JSX } from "preact";
import { useCallback, useEffect, useState } from "preact/hooks";
import { api, errorCode, errorMessage, isSignedIn, kSignedOutEvent, signIn, signOut } from "./api";
import { atLeast, type Me, MeContext, Role, roleName } from "./identity";
import { AdminPage } from "./pages/admin";
import { CapturePage } from "./pages/capture";
import { JobsPage } from "./pages/jobs";
import { LivePage } from "./pages/live";
import { RigPage } from "./pages/rig";
import { SchedulesPage } from "./pages/schedules";
import { SessionsPage } from "./pages/sessions";
import { href, type Route, useRoute } from "./router";
import { Code } from "@connectrpc/connect";

interface PageEntry {
  page: string;
  title: string;
  role: Role;  // the least role that sees the page
  render: (route: Route) => JSX.Element;
}

const kPages: PageEntry[] = [
  { page: "rig", title: "Rig", role: Role.VIEWER, render: () => <RigPage /> },
  { page: "live", title: "Live view", role: Role.OPERATOR, render: () => <LivePage /> },
  { page: "capture", title: "Capture", role: Role.OPERATOR, render: () => <CapturePage /> },
  { page: "jobs", title: "Jobs", role: Role.VIEWER, render: (r) => <JobsPage params={r.params} /> },
  { page: "sessions", title: "Sessions", role: Role.VIEWER,
    render: (r) => <SessionsPage params={r.params} /> },
  { page: "schedules", title: "Schedules", role: Role.VIEWER, render: () => <SchedulesPage /> },
  { page: "admin", title: "Admin", role: Role.ADMIN, render: () => <AdminPage /> },
];

function SignIn({ onSignedIn, notice }: { onSignedIn: () => void; notice?: string }) {
  const [key, setKey] = useState("");
  const [error, setError] = useState<string | undefined>(undefined);
  const [busy, setBusy] = useState(false);
  const submit = async (e: Event) => {
    e.preventDefault();
    setBusy(true);
    setError(undefined);
    try {
      await signIn(key.trim());
      setKey("");
      onSignedIn();
    } catch (err) {
      setError(errorMessage(err));
    } finally {
      setBusy(false);
    }
  };
  return (
    <main class="sign-in">
      <h1>hdrstereo</h1>
      {notice && <p class="notice" role="status">{notice}</p>}
      <form onSubmit={submit}>
        <label for="api-key">API key</label>
        <input id="api-key" type="password" autoComplete="off" value={key}
               onInput={(e) => setKey(e.currentTarget.value)} required
               aria-describedby="api-key-help" aria-invalid={error ? "true" : undefined} />
        <p id="api-key-help" class="help">
          An admin makes one with <code>hdrstereo admin key create</code>. It is sent once,
          to sign in; the page keeps only a session cookie it cannot read.
        </p>
        {error && <p class="error" role="alert" id="sign-in-error">{error}</p>}
        <button type="submit" disabled={busy || key.trim() === ""}>Sign in</button>
      </form>
    </main>
  );
}

export function App() {
  const [me, setMe] = useState<Me | null | undefined>(undefined);
  const [notice, setNotice] = useState<string | undefined>(undefined);
  const [fatal, setFatal] = useState<string | undefined>(undefined);
  const route = useRoute();

  const loadMe = useCallback(async () => {
    try {
      if (!(await isSignedIn())) {
        setMe(null);
        return;
      }
      const id = await api.server.whoAmI({});
      setMe({ principal: id.principal, role: id.role, authMethod: id.authMethod });
      setFatal(undefined);
    } catch (e) {
      if (errorCode(e) === Code.Unauthenticated) setMe(null);
      else setFatal(errorMessage(e));
    }
  }, []);

  useEffect(() => {
    loadMe();
    const onSignedOut = () => {
      setMe((was) => {
        if (was) setNotice("Your session ended (signed out, key revoked or expired, or the daemon restarted). Sign in again.");
        return null;
      });
    };
    window.addEventListener(kSignedOutEvent, onSignedOut);
    return () => window.removeEventListener(kSignedOutEvent, onSignedOut);
  }, [loadMe]);

  if (fatal) return <main class="sign-in"><p class="error" role="alert">{fatal}</p></main>;
  if (me === undefined) return <p class="boot">Connecting…</p>;
  if (me === null) {
    return <SignIn notice={notice} onSignedIn={() => { setNotice(undefined); loadMe(); }} />;
  }

  const visible = kPages.filter((p) => atLeast(me, p.role));
  const current = visible.find((p) => p.page === route.page) ?? visible[0];
  return (
    <MeContext.Provider value={me}>
      <header class="top">
        <a class="brand" href={href("rig")}>hdrstereo</a>
        <nav aria-label="Pages">
          <ul>
            {visible.map((p) => (
              <li key={p.page}>
                <a href={href(p.page)} aria-current={p === current ? "page" : undefined}>{p.title}</a>
              </li>
            ))}
          </ul>
        </nav>
        <div class="who">
          <span data-testid="who">{me.principal} ({roleName(me.role)})</span>
          <button type="button" onClick={async () => { await signOut(); setMe(null); }}>
            Sign out
          </button>
        </div>
      </header>
      <main id="page" aria-label={current.title}>
        {me.role === Role.UNSPECIFIED
          ? <p class="error" role="alert">You are signed in as {me.principal} but hold no role; ask an admin.</p>
          : (
            // Keyed by the whole route: another route (#/jobs/1 → #/jobs/2)
            // mounts a fresh page, so no state, stream or poll of the last
            // one carries over.
            <Fragment key={JSON.stringify([current.page, ...route.params])}>
              {current.render(route)}
            </Fragment>
          )}
      </main>
    </MeContext.Provider>
  );
}
