// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { href, parseRoute } from "../src/router";

test("parseRoute splits the page from its decoded parameters", () => {
  assert.deepEqual(parseRoute(""), { page: "rig", params: [] });
  assert.deepEqual(parseRoute("#/"), { page: "rig", params: [] });
  assert.deepEqual(parseRoute("#/jobs/42"), { page: "jobs", params: ["42"] });
  assert.deepEqual(parseRoute("#/sessions/a%20b/frames/"), { page: "sessions", params: ["a b", "frames"] });
  assert.deepEqual(parseRoute("#/sessions/%C3%A9t%C3%A9"), { page: "sessions", params: ["été"] });
});

test("parseRoute keeps a malformed escape as typed instead of throwing", () => {
  assert.deepEqual(parseRoute("#/sessions/%E0"), { page: "sessions", params: ["%E0"] });
  assert.deepEqual(parseRoute("#/sessions/%/x%41"), { page: "sessions", params: ["%", "xA"] });
  assert.deepEqual(parseRoute("#/sessions/100%25"), { page: "sessions", params: ["100%"] });
});

test("href encodes what parseRoute decodes", () => {
  assert.equal(href("sessions", "a/b c"), "#/sessions/a%2Fb%20c");
  assert.deepEqual(parseRoute(href("sessions", "a/b c", 7n)), { page: "sessions", params: ["a/b c", "7"] });
});
