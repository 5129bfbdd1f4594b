// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { fieldOf, messagePath, placeError } from "../src/field_errors";

test("messagePath joins the parts of a nested path", () => {
  assert.equal(messagePath("plan.captures[0]: bracketed_stereo.baseline_mm is 0; it must be > 0"),
               "plan.captures[0].bracketed_stereo.baseline_mm");
  assert.equal(messagePath("plan.captures[1]: bracketed_stereo: give exposures_s or auto_bracket"),
               "plan.captures[1].bracketed_stereo");
  // The second part is a sentence, not a path.
  assert.equal(messagePath("schedule.cron: cron minute field: \"61\" is out of range"),
               "schedule.cron");
  assert.equal(messagePath("plan.captures[0]: 3 views 150 mm apart"), "plan.captures[0]");
  assert.equal(messagePath("url has no host"), "url");
  assert.equal(messagePath("events: \"job.x\" is not an event type"), "events");
});

test("messagePath is undefined for a message that starts otherwise", () => {
  assert.equal(messagePath("\"x\" is wrong"), undefined);
  assert.equal(messagePath("Schedule is required"), undefined);
  // A path followed by a comma is a list of fields, not one.
  assert.equal(messagePath("schedule.next_due_time, schedule.create_time are output only"),
               undefined);
});

const kFields = ["schedule.name", "schedule.cron", "schedule.time_zone", "plan.session_pattern",
                 "plan.captures", "plan.captures[0]", "plan.captures[0].bracketed_stereo.views",
                 "plan.captures[0].bracketed_stereo.exposures_s", "plan.captures[1]"];

test("fieldOf picks the most specific field the message names", () => {
  assert.equal(fieldOf("plan.captures[0]: bracketed_stereo.views is 20; use 1 to 16", kFields),
               "plan.captures[0].bracketed_stereo.views");
  assert.equal(fieldOf("plan.captures[0]: bracketed_stereo.exposures_s[2] is 0 s", kFields),
               "plan.captures[0].bracketed_stereo.exposures_s");
  assert.equal(fieldOf("plan.captures[0]: bracketed_stereo.baseline_mm is 0", kFields),
               "plan.captures[0]");
  assert.equal(fieldOf("plan.captures[1]: bracketed_stereo.views is 20", kFields),
               "plan.captures[1]");
  assert.equal(fieldOf("plan.captures is empty: a schedule needs at least one capture", kFields),
               "plan.captures");
  assert.equal(fieldOf("schedule.time_zone: time zone \"Mars\" is not a known IANA zone", kFields),
               "schedule.time_zone");
});

test("fieldOf respects segment boundaries", () => {
  assert.equal(fieldOf("schedule.names is odd", kFields), undefined);
  assert.equal(fieldOf("plan.captures[10]: bracketed_stereo.views is 20", kFields),
               "plan.captures");
  assert.equal(fieldOf("alice has no role in [auth.users]", kFields), undefined);
});

test("placeError puts a message at its field or at the top", () => {
  assert.deepEqual(placeError("schedule.name is empty", kFields),
                   { fields: { "schedule.name": "schedule.name is empty" } });
  assert.deepEqual(placeError("the rig is locked by bob", kFields),
                   { fields: {}, top: "the rig is locked by bob" });
});
