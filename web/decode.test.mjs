// decode.test.mjs: checks decode.js against the server's own encoder. tests/service/web_decode.rs
// encodes frames and a mesh in Rust, writes them with the values Rust decodes from them
// to a JSON file, and runs `node web/decode.test.mjs CASES.json`; the exit status is the
// verdict. Not served: the page never loads this file.

import { readFileSync } from "node:fs";
import {
  applyDeltas,
  applyFrame,
  decodeAudio,
  decodeFrame,
  DecodeError,
  motionMatrix,
  parseTextureCoords,
  parseVertexWeights,
  parseMesh,
  readFrameHeader,
} from "./decode.js";

const cases = JSON.parse(readFileSync(process.argv[2], "utf8"));
const failures = [];

function bufferOf(bytes) {
  return new Uint8Array(bytes).buffer;
}

/** Exact comparison: numbers must be identical (f32 values travel as their exact f64). */
function same(actual, expected, path) {
  if (ArrayBuffer.isView(actual)) {
    actual = Array.from(actual);
  }
  if (Array.isArray(expected)) {
    if (!Array.isArray(actual) || actual.length !== expected.length) {
      failures.push(`${path}: length ${actual?.length} != ${expected.length}`);
      return;
    }
    expected.forEach((e, i) => same(actual[i], e, `${path}[${i}]`));
  } else if (expected !== null && typeof expected === "object") {
    for (const key of Object.keys(expected)) {
      same(actual?.[key], expected[key], `${path}.${key}`);
    }
  } else if (!Object.is(actual, expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

/** Column-major 4x4 `m` applied to the point (x, y, z): component `k`. */
function transform(m, x, y, z, k) {
  return m[k] * x + m[4 + k] * y + m[8 + k] * z + m[12 + k];
}

/** Placed positions against the Rust client's, to f32 rounding. */
function near(placed, expected, path) {
  if (Math.abs(placed - expected) > 1e-5 * Math.max(1, Math.abs(expected))) {
    failures.push(`${path}: ${placed} != ${expected}`);
  }
}

async function throwsOn(decode, bytes, field, path) {
  try {
    await decode(bufferOf(bytes));
    failures.push(`${path}: decoded without error, expected one in ${field}`);
  } catch (e) {
    if (!(e instanceof DecodeError)) {
      failures.push(`${path}: threw ${e}, not a DecodeError`);
    } else if (e.field !== field) {
      failures.push(`${path}: error in ${e.field} (${e.message}), expected ${field}`);
    }
  }
}

for (const [i, c] of cases.frames.entries()) {
  const path = `frame ${i} (${c.name})`;
  const buffer = bufferOf(c.bytes);
  same(readFrameHeader(buffer), c.header, `${path} header`);
  const frame = await decodeFrame(buffer);
  same(frame, c.header, path);
  same(frame.lip.perVertex, c.lipPerVertex, `${path} lip.perVertex`);
  same(frame.label, c.label, `${path} label`);
  same(frame.movedIndices, c.movedIndices, `${path} movedIndices`);
  same(frame.movedCounts, c.movedCounts, `${path} movedCounts`);
  same(frame.face, c.face, `${path} face`);
  same(frame.head, c.head, `${path} head`);
  same(frame.jaw, c.jaw, `${path} jaw`);
  same(frame.tongue, c.tongue, `${path} tongue`);
  same(frame.folds, c.folds, `${path} folds`);
  same(frame.eyes, c.eyes, `${path} eyes`);
  const positions = applyFrame(new Float32Array(c.rest), frame, new Float32Array(c.rest.length));
  same(positions, c.positions, `${path} positions`);
  // The matrix the page draws with puts every vertex where the Rust client places it.
  const m = motionMatrix(frame.head);
  for (let v = 0; v < positions.length / 3; v++) {
    const [x, y, z] = positions.subarray(v * 3, v * 3 + 3);
    for (let k = 0; k < 3; k++) {
      near(transform(m, x, y, z, k), c.placed[v * 3 + k], `${path} placed[${v}][${k}]`);
    }
  }
  // The tongue: its deltas on its rest, then the jaw's matrix, then the head's.
  if (frame.tongue) {
    const rest = new Float32Array(c.tongueRest);
    const tongue = applyDeltas(rest, frame.tongue, frame.step, new Float32Array(rest.length));
    same(tongue, c.tonguePositions, `${path} tongue positions`);
    const jaw = motionMatrix(frame.jaw);
    for (let v = 0; v < tongue.length / 3; v++) {
      const [x, y, z] = tongue.subarray(v * 3, v * 3 + 3);
      const [jx, jy, jz] = [0, 1, 2].map((k) => transform(jaw, x, y, z, k));
      for (let k = 0; k < 3; k++) {
        near(transform(m, jx, jy, jz, k), c.tonguePlaced[v * 3 + k], `${path} tongue placed[${v}][${k}]`);
      }
    }
  }
}
for (const [i, c] of cases.malformedFrames.entries()) {
  await throwsOn(decodeFrame, c.bytes, c.field, `malformed frame ${i} (${c.name})`);
}

for (const c of cases.audio) {
  same(decodeAudio(bufferOf(c.bytes)), c.expected, `audio (${c.name})`);
}
for (const c of cases.malformedAudio) {
  await throwsOn(decodeAudio, c.bytes, c.field, `malformed audio (${c.name})`);
}

same(parseMesh(bufferOf(cases.mesh.bytes)), cases.mesh.expected, "mesh");
for (const [i, c] of cases.malformedMeshes.entries()) {
  await throwsOn(parseMesh, c.bytes, c.field, `malformed mesh ${i} (${c.name})`);
}

const lips = parseVertexWeights(bufferOf(cases.lipTint.bytes), cases.lipTint.vertexCount);
same([...lips], cases.lipTint.expected, "lip tint");
for (const c of cases.malformedLipTints) {
  await throwsOn((buffer) => parseVertexWeights(buffer, cases.lipTint.vertexCount), c.bytes, c.field, `malformed lip tint (${c.name})`);
}

const uv = parseTextureCoords(bufferOf(cases.textureCoords.bytes), cases.textureCoords.triangleCount);
same([...uv.coords], cases.textureCoords.coords, "texture coordinates");
same([...uv.corners], cases.textureCoords.corners, "texture corners");
for (const c of cases.malformedTextureCoords) {
  await throwsOn((buffer) => parseTextureCoords(buffer, cases.textureCoords.triangleCount), c.bytes, c.field, `malformed uv.bin (${c.name})`);
}

if (failures.length > 0) {
  console.error(`${failures.length} mismatch(es):\n${failures.slice(0, 40).join("\n")}`);
  process.exit(1);
}
console.log(
  `decode.js agrees with the Rust encoder on ${cases.frames.length} frames, ${cases.audio.length} audio chunks, a mesh, its lip tint and its texture coordinates`,
);
