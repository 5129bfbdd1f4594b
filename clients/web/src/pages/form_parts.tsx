// SPDX-License-Identifier: GPL-3.0-or-later
//
// Pieces the forms share: a labelled form field that shows its error, a
// button that asks before it acts, a box that shows a secret once, and the
// image formats a plan may ask for.
import type { ComponentChildren, JSX } from "preact";
import { useEffect, useRef, useState } from "preact/hooks";
import { ImageFormat } from "../../gen/hdrstereo/v1/common_pb";
import { errorMessage } from "../api";

export interface FieldInputProps {
  id: string;
  "aria-invalid"?: "true";
  "aria-describedby"?: string;
}

// A label, an input (rendered by `children` with the ids it needs), help
// and the field's error under it.
export function Field({ id, label, help, error, wide, children }: {
  id: string; label: string; help?: ComponentChildren; error?: string;
  wide?: boolean;  // two columns of a .form-grid
  children: (props: FieldInputProps) => JSX.Element;
}) {
  const described = [help && `${id}-help`, error && `${id}-error`].filter(Boolean).join(" ");
  return (
    <div class={wide ? "field wide" : "field"}>
      <label for={id}>{label}</label>
      {children({ id, "aria-invalid": error ? "true" : undefined,
                  "aria-describedby": described || undefined })}
      {help && <p class="help" id={`${id}-help`}>{help}</p>}
      {error && <p class="field-error" id={`${id}-error`}>{error}</p>}
    </div>
  );
}

// A checkbox with its label after it, and its error.
export function Check({ id, label, checked, onChange, error, disabled }: {
  id: string; label: string; checked: boolean; onChange: (v: boolean) => void;
  error?: string; disabled?: boolean;
}) {
  return (
    <div class="checkline">
      <input id={id} type="checkbox" checked={checked} disabled={disabled}
             aria-invalid={error ? "true" : undefined}
             aria-describedby={error ? `${id}-error` : undefined}
             onChange={(e) => onChange(e.currentTarget.checked)} />
      <label for={id}>{label}</label>
      {error && <p class="field-error" id={`${id}-error`}>{error}</p>}
    </div>
  );
}

// A table that scrolls sideways when narrow: a named region that takes the
// focus, so the keyboard can scroll it too.
export function TableWrap({ label, children }: { label: string; children: ComponentChildren }) {
  return <div class="table-wrap" role="region" aria-label={label} tabIndex={0}>{children}</div>;
}

// A button that asks `question` before running `act`; the question takes
// the focus, Cancel (or `keepLabel`) gives it back. A refused call shows
// the server's words.
export function ConfirmButton({ label, question, confirmLabel, keepLabel = "Cancel", act }: {
  label: string; question: string; confirmLabel: string; keepLabel?: string;
  act: () => Promise<unknown>;
}) {
  const [asking, setAsking] = useState(false);
  const [busy, setBusy] = useState(false);
  const [error, setError] = useState<string | undefined>(undefined);
  const yes = useRef<HTMLButtonElement>(null);
  const trigger = useRef<HTMLButtonElement>(null);
  const wasAsking = useRef(false);
  useEffect(() => {
    if (asking) yes.current?.focus();
    else if (wasAsking.current) trigger.current?.focus();
    wasAsking.current = asking;
  }, [asking]);
  const confirm = async () => {
    setBusy(true);
    setError(undefined);
    try {
      await act();
      setAsking(false);
    } catch (e) {
      setError(errorMessage(e));
    } finally {
      setBusy(false);
    }
  };
  if (!asking) {
    return (
      <span class="confirm-action">
        <button type="button" class="danger" ref={trigger} onClick={() => setAsking(true)}>{label}</button>
        {error && <span class="field-error" role="alert">{error}</span>}
      </span>
    );
  }
  return (
    <span class="confirm-action asking" role="group" aria-label={question}>
      <span>{question}</span>
      <button type="button" class="danger" ref={yes} disabled={busy} onClick={confirm}>
        {confirmLabel}
      </button>
      <button type="button" class="secondary" disabled={busy} onClick={() => setAsking(false)}>
        {keepLabel}
      </button>
      {error && <span class="field-error" role="alert">{error}</span>}
    </span>
  );
}

// A modal box showing a secret once, with a Copy button (the clipboard, or
// else the text selected for Ctrl+C). Closing it (Done or Escape) calls
// onClose, whose caller forgets the secret.
export function ShownOnce({ title, label, secret, children, onClose }: {
  title: string; label: string; secret: string; children?: ComponentChildren; onClose: () => void;
}) {
  const dialog = useRef<HTMLDialogElement>(null);
  const text = useRef<HTMLTextAreaElement>(null);
  const [copied, setCopied] = useState<string | undefined>(undefined);
  useEffect(() => {
    if (!dialog.current?.open) dialog.current?.showModal();
  }, []);
  const select = () => {
    text.current?.focus();
    text.current?.select();
  };
  const copy = async () => {
    try {
      if (!navigator.clipboard) throw new Error("no clipboard");
      await navigator.clipboard.writeText(secret);
      setCopied("Copied to the clipboard.");
    } catch {
      select();
      setCopied("The browser did not allow copying: the text is selected, press Ctrl+C (⌘C on a Mac).");
    }
  };
  return (
    <dialog ref={dialog} class="shown-once" aria-labelledby="shown-once-title" onClose={onClose}>
      <h2 id="shown-once-title">{title}</h2>
      {children}
      <label for="shown-once-secret">{label}</label>
      <div class="row">
        <textarea id="shown-once-secret" ref={text} class="mono secret" readOnly value={secret}
                  rows={2} spellcheck={false} onFocus={select} />
        <button type="button" onClick={copy}>Copy</button>
      </div>
      <p class="status" role="status">{copied}</p>
      <p class="notice"><strong>It will not be shown again.</strong> Store it now; the daemon
        keeps only what it needs to check it.</p>
      <form method="dialog">
        <button type="submit">Done: I have stored it</button>
      </form>
    </dialog>
  );
}

// The <option>s of an image-format <select>, values the enum's numbers.
export function ImageFormatOptions() {
  return (
    <>
      <option value={String(ImageFormat.UNSPECIFIED)}>The camera's current</option>
      <option value={String(ImageFormat.JPEG)}>JPEG</option>
      <option value={String(ImageFormat.RAW)}>RAW</option>
      <option value={String(ImageFormat.RAW_AND_JPEG)}>RAW + JPEG</option>
      <option value={String(ImageFormat.TIFF_16)}>16-bit TIFF (simulated camera)</option>
      <option value={String(ImageFormat.PNG_8)}>8-bit PNG (simulated camera)</option>
    </>
  );
}
