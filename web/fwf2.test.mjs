// fwf2.test.mjs: checks decode.js's FWF2 path on real content before FWF2 fixtures exist,
// and its refusals after. `node web/fwf2.test.mjs proto/fixtures/fwf1` re-encodes each
// FWF1 fixture as FWF2 (proto/PROTOCOL.md; delta blocks copied verbatim: both layouts share
// their format and deflate) and checks that it decodes to the fixture's digest in
// expected.json, as sent, in reverse order, and as a later server might send it (every
// section grown by 3 bytes, an extra section of unknown kind 200); then that malformed
// variants throw a DecodeError naming the right field. The exit status is the verdict. Not
// served.

import { readFileSync } from "node:fs";
import { join } from "node:path";
import { decodeFrame, DecodeError, readFrameHeader } from "./decode.js";
import { differences, digest, readFrameFile } from "./fixtures.test.mjs";

const [DELTAS, LIP_ROUGHNESS, LABEL, HEAD_MOTION, JAW_MOTION, LIP_FOLDS, PART_DELTAS, HEAT] = [1, 2, 3, 4, 5, 6, 7, 8];

const bytesOf = (...parts) => new Uint8Array(Buffer.concat(parts));

function u32(n) {
  const b = new Uint8Array(4);
  new DataView(b.buffer).setUint32(0, n, true);
  return b;
}

/** An FWF1 frame's content as FWF2 sections, `[kind, body]` in increasing kind. */
function sectionsOf(m) {
  const view = new DataView(m.buffer, m.byteOffset, m.byteLength);
  const flags = m[4];
  let at = 52;
  const cut = (n) => m.subarray(at, (at += n));
  const block = () => cut(4 + view.getUint32(at, true));
  const encoding = Uint8Array.of(flags & 4 ? 1 : 0); // bit 2: deflated
  const step = m.subarray(40, 44);
  const sections = [[LIP_ROUGHNESS, cut(13 + 4 * m[64])]];
  // FWF1's flag bit, the section, its length (the label's from its first byte).
  const optional = [
    [2, LABEL, () => 1 + m[at]],
    [8, HEAD_MOTION, () => 28],
    [16, JAW_MOTION, () => 28],
    [64, LIP_FOLDS, () => 8],
  ];
  for (const [flag, kind, length] of optional) {
    if (flags & flag) {
      sections.push([kind, cut(length())]);
    }
  }
  sections.push([DELTAS, bytesOf(step, m.subarray(44, 52), encoding, block())]);
  if (flags & 32) {
    // Tongue deltas: part, vertex_count and moved, then the block.
    const [part, counts] = [cut(1), cut(8)];
    sections.push([PART_DELTAS, bytesOf(part, step, counts, encoding, block())]);
  }
  if (flags & 1) {
    // Per-vertex values: max, then a byte per vertex.
    const max = cut(4);
    sections.push([HEAT, bytesOf(max, m.subarray(44, 48), cut(view.getUint32(44, true)))]);
  }
  if (at !== m.length) {
    throw new Error(`FWF1 walk ended at byte ${at} of ${m.length}`);
  }
  return sections.sort((a, b) => a[0] - b[0]);
}

/** The FWF2 frame of `fwf1`'s timing with `sections`. */
function encode(fwf1, sections) {
  const framed = sections.flatMap(([kind, body]) => [Uint8Array.of(kind), u32(body.length), body]);
  return bytesOf(Buffer.from("FWF2"), fwf1.subarray(8, 40), Uint8Array.of(sections.length), ...framed);
}

/** `sections` with the body of `kind` replaced by `change(body)`, or null without one. */
function withBody(sections, kind, change) {
  if (!sections.some(([k]) => k === kind)) {
    return null;
  }
  return sections.map(([k, body]) => [k, k === kind ? change(body) : body]);
}

/** `sections` with the one of `kind` given twice, or null without one. */
function twice(sections, kind) {
  const section = sections.find(([k]) => k === kind);
  return section ? [...sections, section] : null;
}

/** A copy of `bytes` with byte `i` set to `value`. */
function withByte(bytes, i, value) {
  const copy = bytes.slice();
  copy[i] = value;
  return copy;
}

/** `[field, the FWF2 frame of sections]`, or null when `sections` is (the fixture lacks a kind). */
const refusedAs = (field, fwf1, sections) => (sections ? [field, encode(fwf1, sections)] : null);

const GROWN = Uint8Array.of(0xee, 0xee, 0xee);
/** Variants that must decode to the fixture's digest: name, sections from the fixture's. */
const READABLE = [
  ["FWF2", (s) => s],
  ["reversed", (s) => [...s].reverse()],
  ["later server", (s) => [[200, Uint8Array.of(9, 9)], ...s.map(([kind, body]) => [kind, bytesOf(body, GROWN)])]],
];

/** Variants that must be refused: name, `(fwf1, sections) => [field, bytes]` or null. */
const MALFORMED = [
  ["last section past the end", (f, s) => ["section", encode(f, s).subarray(0, -1)]],
  ["count past the last section", (f, s) => ["section", withByte(encode(f, s), 36, s.length + 1)]],
  ["a byte after the last section", (f, s) => ["end", bytesOf(encode(f, s), Uint8Array.of(0))]],
  ["lip_roughness twice", (f, s) => refusedAs("lip_roughness", f, twice(s, LIP_ROUGHNESS))],
  ["a part twice", (f, s) => refusedAs("part_deltas", f, twice(s, PART_DELTAS))],
  ["no deltas", (f, s) => refusedAs("deltas", f, s.filter(([k]) => k !== DELTAS))],
  ["no lip_roughness", (f, s) => refusedAs("lip_roughness", f, s.filter(([k]) => k !== LIP_ROUGHNESS))],
  ["encoding 2", (f, s) => refusedAs("encoding", f, withBody(s, DELTAS, (b) => withByte(b, 12, 2)))],
  ["lip folds cut short", (f, s) => refusedAs("lip folds", f, withBody(s, LIP_FOLDS, (b) => b.subarray(0, 6)))],
];

/** Null when decoding `bytes` throws a DecodeError in `field`, else what happened instead. */
async function refusal(bytes, field) {
  try {
    await decodeFrame(bytes.slice().buffer);
    return `decoded, expected a DecodeError in ${field}`;
  } catch (e) {
    if (!(e instanceof DecodeError)) {
      return `threw ${e}, not a DecodeError`;
    }
    return e.field === field ? null : `error in ${e.field} (${e.message}), expected ${field}`;
  }
}

if (process.argv.length !== 3) {
  console.error("usage: node web/fwf2.test.mjs FWF1_FIXTURES_DIR (proto/fixtures/fwf1)");
  process.exit(2);
}
const dir = process.argv[2];
const expected = JSON.parse(readFileSync(join(dir, "expected.json"), "utf8"));
const failures = [];
let refused = 0;
for (const [file, want] of Object.entries(expected)) {
  const fwf1 = new Uint8Array(readFrameFile(join(dir, file)));
  const sections = sectionsOf(fwf1);
  for (const [name, variant] of READABLE) {
    const bytes = encode(fwf1, variant(sections));
    const frame = await decodeFrame(bytes.slice().buffer).catch((e) => e);
    if (frame instanceof Error) {
      failures.push(`${file} ${name}: ${frame.message}`);
      continue;
    }
    failures.push(...differences(digest(frame), want, `${file} ${name}`));
    const header = readFrameHeader(bytes.slice().buffer);
    failures.push(...differences(header, readFrameHeader(fwf1.buffer), `${file} ${name} header`));
  }
  for (const [name, variant] of MALFORMED) {
    const malformed = variant(fwf1, sections);
    if (malformed) {
      const problem = await refusal(malformed[1], malformed[0]);
      refused += 1;
      if (problem) {
        failures.push(`${file} ${name}: ${problem}`);
      }
    }
  }
}
for (const failure of failures) {
  console.error(failure);
}
const frames = Object.keys(expected).length;
const verdict = failures.length === 0 ? "all as expected" : `${failures.length} failure(s)`;
console.log(`fwf2: ${frames} fixtures as FWF2 x ${READABLE.length} readable variants, ${refused} malformed ones; ${verdict}`);
process.exit(failures.length === 0 ? 0 : 1);
