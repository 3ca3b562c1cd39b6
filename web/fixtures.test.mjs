// fixtures.test.mjs: holds decode.js to the viewer frames captured from real servers
// (proto/fixtures/, whose README defines the digest). `node web/fixtures.test.mjs
// proto/fixtures` decodes every `.bin` that each subdirectory's expected.json lists and
// compares its digest with the one recorded there, exactly: f32 values widened to doubles,
// numbers compared with Object.is. A new directory (a new layout, a later server's frames)
// is checked as soon as it exists. The exit status is the verdict. Not served: the page
// never loads this file; fwf2.test.mjs imports its digest.

import { existsSync, readdirSync, readFileSync } from "node:fs";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import { decodeFrame } from "./decode.js";

/** A file's bytes as the ArrayBuffer a socket would give. */
export function readFrameFile(path) {
  return new Uint8Array(readFileSync(path)).buffer;
}

/** The digest of moved entries `(index, cx, cy, cz)`: decoded `{movedIndices, movedCounts}`. */
function movedDigest({ movedIndices, movedCounts }) {
  const count = movedIndices.length;
  const entry = (i) => [movedIndices[i], ...movedCounts.subarray(3 * i, 3 * i + 3)];
  const sum = [0, 0, 0];
  const absSum = [0, 0, 0];
  let indexSum = 0;
  for (let i = 0; i < count; i++) {
    indexSum += movedIndices[i];
    for (let k = 0; k < 3; k++) {
      sum[k] += movedCounts[3 * i + k];
      absSum[k] += Math.abs(movedCounts[3 * i + k]);
    }
  }
  const [first, last] = count > 0 ? [entry(0), entry(count - 1)] : [null, null];
  return { count, index_sum: indexSum, sum, abs_sum: absSum, first, last };
}

/** The per-vertex values' digest: the bytes recovered from the values and the section's max. */
function heatDigest(values, max) {
  const bytes = Array.from(values, (v) => (max === 0 ? 0 : Math.round((v / max) * 255)));
  return {
    count: bytes.length,
    max,
    byte_sum: bytes.reduce((s, b) => s + b, 0),
    weighted_byte_sum: bytes.reduce((s, b, i) => s + i * b, 0),
  };
}

/** A rigid motion as plain arrays. */
function motionDigest({ rotation, translation }) {
  return { rotation: [...rotation], translation: [...translation] };
}

/** A decoded frame's digest, as proto/fixtures/README.md defines it. */
export function digest(frame) {
  const { folds } = frame;
  return {
    seq: frame.seq,
    t: frame.producerTimeS,
    server_receive_us: frame.serverReceiveUs,
    server_send_us: frame.serverSendUs,
    step: frame.step,
    vertex_count: frame.vertexCount,
    moved: movedDigest(frame),
    lip: { min: frame.lip.min, max: frame.lip.max, mean: frame.lip.mean, per_vertex: Array.from(frame.lip.perVertex) },
    label: frame.label,
    head: motionDigest(frame.head),
    jaw: motionDigest(frame.jaw),
    folds: folds === null ? null : {
      turned_over_60: folds.turnedOver60,
      turned_over_90: folds.turnedOver90,
      max_dihedral_increase_deg: folds.maxDihedralIncreaseDeg,
    },
    parts: frame.parts.map((p) => ({ part: p.part, vertex_count: p.vertexCount, moved: movedDigest(p) })),
    heat: frame.face === null ? null : heatDigest(frame.face, frame.faceMax),
  };
}

/** Where JSON-like `actual` and `expected` differ: same keys, same lengths, Object.is on numbers. */
export function differences(actual, expected, path) {
  if (Array.isArray(expected)) {
    if (!Array.isArray(actual) || actual.length !== expected.length) {
      return [`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`];
    }
    return expected.flatMap((e, i) => differences(actual[i], e, `${path}[${i}]`));
  }
  if (expected !== null && typeof expected === "object") {
    if (actual === null || typeof actual !== "object" || Array.isArray(actual)) {
      return [`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`];
    }
    const keys = [...new Set([...Object.keys(expected), ...Object.keys(actual)])];
    return keys.flatMap((key) => differences(actual[key], expected[key], `${path}.${key}`));
  }
  return Object.is(actual, expected) ? [] : [`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`];
}

/** Checks one fixture directory: `{checked, failures}`. */
async function checkDirectory(dir, name) {
  const expected = JSON.parse(readFileSync(join(dir, "expected.json"), "utf8"));
  const failures = readdirSync(dir)
    .filter((file) => file.endsWith(".bin") && !Object.hasOwn(expected, file))
    .map((file) => `${name}/${file}: not in expected.json`);
  for (const [file, want] of Object.entries(expected)) {
    try {
      const frame = await decodeFrame(readFrameFile(join(dir, file)));
      failures.push(...differences(digest(frame), want, `${name}/${file}`));
    } catch (e) {
      failures.push(`${name}/${file}: ${e.message}`);
    }
  }
  return { checked: Object.keys(expected).length, failures };
}

async function main(root) {
  const names = readdirSync(root, { withFileTypes: true })
    .filter((d) => d.isDirectory() && existsSync(join(root, d.name, "expected.json")))
    .map((d) => d.name)
    .sort();
  const failures = names.length > 0 ? [] : [`${root}: no subdirectory with an expected.json`];
  const counts = [];
  for (const name of names) {
    const result = await checkDirectory(join(root, name), name);
    failures.push(...result.failures);
    counts.push(`${name} ${result.checked}`);
  }
  for (const failure of failures) {
    console.error(failure);
  }
  const verdict = failures.length === 0 ? "every digest as expected" : `${failures.length} mismatch(es)`;
  console.log(`fixtures: frames checked per directory: ${counts.join(", ") || "none"}; ${verdict}`);
  process.exit(failures.length === 0 ? 0 : 1);
}

if (import.meta.url === pathToFileURL(process.argv[1]).href) {
  if (process.argv.length !== 3) {
    console.error("usage: node web/fixtures.test.mjs FIXTURES_DIR (proto/fixtures)");
    process.exit(2);
  }
  await main(process.argv[2]);
}
