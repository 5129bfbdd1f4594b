// SPDX-License-Identifier: GPL-3.0-or-later
//
// Puts a server's validation message at the form field it names. The
// daemon starts such messages with the request's field path, sometimes in
// two parts ("plan.captures[0]: bracketed_stereo.baseline_mm is 0; ...",
// "schedule.cron: cron minute field: ..."); a form knows the paths of its
// fields and gets the longest one the message's path starts with, or none
// (then the message belongs at the top of the form).

const kSegment = /^[a-z][a-z0-9_]*(\[\d+\])?/;

// The leading `a.b[2].c` of `text` and what follows it, or undefined.
function takePath(text: string): { path: string; rest: string } | undefined {
  let path = "";
  let rest = text;
  for (;;) {
    const m = kSegment.exec(rest);
    if (!m) return undefined;
    path += m[0];
    rest = rest.slice(m[0].length);
    if (!rest.startsWith(".")) break;
    path += ".";
    rest = rest.slice(1);
  }
  // A path ends the message or is followed by a space or a colon.
  if (rest !== "" && !rest.startsWith(" ") && !rest.startsWith(":")) return undefined;
  return { path, rest };
}

// The field path a message starts with, its parts joined ("plan.captures[0]:
// bracketed_stereo.views is 20" -> "plan.captures[0].bracketed_stereo.views");
// undefined when it starts with a plain word.
export function messagePath(message: string): string | undefined {
  const first = takePath(message);
  if (!first) return undefined;
  let { path, rest } = first;
  // A second part counts when it is itself a path: dotted, indexed or
  // followed by its own colon (not the first word of a sentence).
  while (rest.startsWith(": ")) {
    const next = takePath(rest.slice(2));
    if (!next || !(/[.[]/.test(next.path) || next.rest.startsWith(":"))) break;
    path += `.${next.path}`;
    rest = next.rest;
  }
  return path;
}

// True when `path` is `field` or lies under it (field "a.b" covers "a.b",
// "a.b.c" and "a.b[3]", not "a.bc").
function covers(field: string, path: string): boolean {
  if (!path.startsWith(field)) return false;
  const next = path.charAt(field.length);
  return next === "" || next === "." || next === "[";
}

// Of `fields` (a form's field paths), the most specific one `message` names;
// undefined when it names none of them.
export function fieldOf(message: string, fields: readonly string[]): string | undefined {
  const path = messagePath(message);
  if (path === undefined) return undefined;
  let best: string | undefined;
  for (const field of fields) {
    if (covers(field, path) && (best === undefined || field.length > best.length)) best = field;
  }
  return best;
}

// A form's errors: by field path, and the rest at its top.
export interface FormErrors {
  top?: string;
  fields: Record<string, string>;
}

export const kNoErrors: FormErrors = { fields: {} };

// The errors to show for a refused call's message.
export function placeError(message: string, fields: readonly string[]): FormErrors {
  const field = fieldOf(message, fields);
  return field === undefined ? { fields: {}, top: message } : { fields: { [field]: message } };
}
