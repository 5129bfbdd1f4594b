// SPDX-License-Identifier: GPL-3.0-or-later
import assert from "node:assert/strict";
import { test } from "node:test";
import { kMaxPfmSide, parsePfm, pfmAt, PfmError } from "../src/pfm";

// A PFM from its header and float values (file order: bottom row first).
function pfm(header: string, values: number[], littleEndian: boolean, dropBytes = 0): ArrayBuffer {
  const head = new TextEncoder().encode(header);
  const bytes = new Uint8Array(head.length + values.length * 4);
  bytes.set(head);
  const view = new DataView(bytes.buffer);
  values.forEach((v, i) => view.setFloat32(head.length + 4 * i, v, littleEndian));
  return bytes.buffer.slice(0, bytes.length - dropBytes);
}

test("grey 2x2 little-endian: rows bottom to top become top to bottom", () => {
  // File rows: bottom (y=1) = [1, 2], top (y=0) = [3, 4].
  const p = parsePfm(pfm("Pf\n2 2\n-1.0\n", [1, 2, 3, 4], true));
  assert.equal(p.width, 2);
  assert.equal(p.height, 2);
  assert.equal(p.channels, 1);
  assert.equal(p.littleEndian, true);
  assert.equal(p.scale, 1);
  assert.deepEqual([...p.data], [3, 4, 1, 2]);
  assert.equal(pfmAt(p, 0, 0), 3);
  assert.equal(pfmAt(p, 1, 1), 2);
});

test("grey 2x2 big-endian (positive scale) reads the same values", () => {
  const p = parsePfm(pfm("Pf\n2 2\n1.0\n", [1.5, -2.25, Infinity, NaN], false));
  assert.equal(p.littleEndian, false);
  assert.equal(pfmAt(p, 0, 0), Infinity);
  assert.ok(Number.isNaN(pfmAt(p, 1, 0)));
  assert.equal(pfmAt(p, 0, 1), 1.5);
  assert.equal(pfmAt(p, 1, 1), -2.25);
});

test("the same values in either byte order parse alike", () => {
  const v = [0.1, 2e-7, 3e5, -0];
  const le = parsePfm(pfm("Pf\n2 2\n-1\n", v, true));
  const be = parsePfm(pfm("Pf\n2 2\n1\n", v, false));
  assert.deepEqual([...le.data], [...be.data]);
  assert.equal(le.data[0], Math.fround(3e5));
});

test("colour 2x2, both byte orders, channels interleaved", () => {
  // bottom row: (1,2,3) (4,5,6); top row: (7,8,9) (10,11,12)
  const values = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12];
  for (const [scale, le] of [["-1.0", true], ["1.0", false]] as const) {
    const p = parsePfm(pfm(`PF\n2 2\n${scale}\n`, values, le));
    assert.equal(p.channels, 3);
    assert.deepEqual([...p.data], [7, 8, 9, 10, 11, 12, 1, 2, 3, 4, 5, 6]);
    assert.equal(pfmAt(p, 1, 0, 2), 12);
    assert.equal(pfmAt(p, 0, 1, 1), 2);
  }
});

test("header whitespace may be spaces or newlines; scale keeps its magnitude", () => {
  const p = parsePfm(pfm("Pf 2 1 -4.0\n", [5, 6], true));
  assert.equal(p.height, 1);
  assert.equal(p.scale, 4);
  assert.deepEqual([...p.data], [5, 6]);
});

function throwsPfm(buffer: ArrayBuffer, message: RegExp) {
  assert.throws(() => parsePfm(buffer), (e: unknown) => {
    assert.ok(e instanceof PfmError, `not a PfmError: ${e}`);
    assert.match((e as Error).message, message);
    return true;
  });
}

test("hostile headers fail with a message before allocating", () => {
  throwsPfm(pfm("Pf\n-2 2\n-1.0\n", [], true), /^PFM: width "-2" is not a positive integer$/);
  throwsPfm(pfm("Pf\n2 0\n-1.0\n", [], true), /^PFM: height 0 is outside 1\.\.16384$/);
  throwsPfm(pfm(`Pf\n${kMaxPfmSide + 1} 2\n-1.0\n`, [], true), /^PFM: width 16385 is outside 1\.\.16384$/);
  throwsPfm(pfm("Pf\n16384 16384\n-1.0\n", [], true),
            /^PFM: 16384x16384x1 is more than 134217728 values$/);
  // A 24 MP DSLR's radiance map is within the limits: only its data is
  // missing here.
  throwsPfm(pfm("PF\n6000 4000\n-1.0\n", [], true),
            /^PFM: 6000x4000x3 needs 288000000 bytes of data, the file has 0 \(truncated\)$/);
  throwsPfm(pfm("Pf\n1e3 2\n-1.0\n", [], true), /width "1e3" is not a positive integer/);
  throwsPfm(pfm("P6\n2 2\n255\n", [], true), /^PFM: unknown type "P6" \(expected PF or Pf\)$/);
  throwsPfm(pfm("Pf\n2 2\n0\n", [1, 2, 3, 4], true), /^PFM: scale "0" is not a non-zero number$/);
  throwsPfm(pfm("Pf\n2 2\nabc\n", [1, 2, 3, 4], true), /scale "abc" is not a non-zero number/);
  throwsPfm(pfm("Pf\n2 2", [], true), /^PFM: the file ends inside its header/);
  throwsPfm(new ArrayBuffer(0), /the file ends inside its header/);
  throwsPfm(new TextEncoder().encode("x".repeat(300)).buffer as ArrayBuffer,
            /^PFM: no complete header in the first 256 bytes$/);
});

test("truncated or overlong data is refused with the byte counts", () => {
  throwsPfm(pfm("Pf\n2 2\n-1.0\n", [1, 2, 3, 4], true, 1),
            /^PFM: 2x2x1 needs 16 bytes of data, the file has 15 \(truncated\)$/);
  throwsPfm(pfm("PF\n2 2\n-1.0\n", [1, 2, 3, 4], true),
            /^PFM: 2x2x3 needs 48 bytes of data, the file has 16 \(truncated\)$/);
  throwsPfm(pfm("Pf\n2 2\n-1.0\n", [1, 2, 3, 4, 5], true),
            /^PFM: 2x2x1 needs 16 bytes of data, the file has 20$/);
});
