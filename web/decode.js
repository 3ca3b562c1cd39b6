// decode.js: reads the server's binary formats into typed arrays: the rest mesh
// (`mesh.bin`, "FWM1"), where its lips are (`lips.bin`, "FWL1"), where it sits on its
// texture (`uv.bin`, "FWU1"), the viewer frame, in
// either layout (proto/PROTOCOL.md): the sectioned "FWF2" the page asks for, and the
// frozen "FWF1" that a server before FWF2 sends, and the audio chunk ("FWA1").
// Both decode to the same object, so the page does not care which arrived. It touches no
// DOM, so node runs it in tests/service/web_decode.rs against frames from the server's own encoder
// and in fixtures.test.mjs against frames captured from real servers. Every length is
// checked: a bad message throws a DecodeError naming the field and byte. A deflated delta
// block is inflated by the browser's own DecompressionStream, which is why decodeFrame
// returns a promise.

const MESH_MAGIC = "FWM1";
const VERTEX_WEIGHTS_MAGIC = "FWL1";
const TEXTURE_COORDS_MAGIC = "FWU1";
const FWF1_MAGIC = "FWF1";
const FWF2_MAGIC = "FWF2";
const AUDIO_MAGIC = "FWA1";
const FLAG_FACE = 1;
const FLAG_LABEL = 2;
const FLAG_DEFLATE = 4;
const FLAG_HEAD = 8;
const FLAG_JAW = 16;
const FLAG_TONGUE = 32;
const FLAG_FOLDS = 64;
/** FWF1's `moved`, which its error for a block too short for its entries names. */
const FWF1_MOVED = Object.freeze({ field: "moved", at: 48 });
/** FWF2's section kinds by number; a kind not here is from a later server and skipped. */
const SECTION_NAMES = new Map([
  [1, "deltas"],
  [2, "lip_roughness"],
  [3, "label"],
  [4, "head_motion"],
  [5, "jaw_motion"],
  [6, "lip_folds"],
  [7, "part_deltas"],
  [8, "heat"],
  [9, "eye_motion"],
  [10, "viseme"],
]);
/** FWF2 sections a frame may hold several of (one per part, one per eye). */
const REPEATED_SECTIONS = new Set(["part_deltas", "eye_motion"]);
/** FWA1's section kinds; exactly one of them is in a chunk. */
const AUDIO_SECTION_NAMES = new Map([
  [1, "pcm"],
  [2, "opus"],
]);
/** The sample rates of a PCM chunk, Hz. */
const PCM_RATES = [16000, 24000, 48000];
/** Opus packets decode at 48 kHz; RFC 6716's largest packet, bytes. */
export const OPUS_RATE = 48000;
const MAX_OPUS_PACKET = 1275;
/** An FWF2 delta block's `encoding` byte. */
const ENCODING_PLAIN = 0;
const ENCODING_DEFLATE = 1;
/** How far from 1 a head rotation quaternion's length may be. */
const UNIT_QUATERNION_TOLERANCE = 1e-4;
/** No motion (the head or the jaw at rest): rotation quaternion x, y, z, w and translation (head units). */
export const AT_REST = Object.freeze({ rotation: [0, 0, 0, 1], translation: [0, 0, 0] });
const I32_MIN = -(2 ** 31);
const I32_MAX = 2 ** 31 - 1;
/** Zigzag of the largest difference of two i32 counts. */
const MAX_DIFFERENCE = 2 ** 33;

export class DecodeError extends Error {
  constructor(field, at, problem) {
    super(`byte ${at}: ${field}: ${problem}`);
    this.name = "DecodeError";
    this.field = field;
    this.at = at;
  }
}

/**
 * Little-endian reader over a Uint8Array, or over `bytes[at..end]` (an FWF2 section's
 * body, offsets still the message's), that names the field on every short read.
 */
class Reader {
  constructor(bytes, at = 0, end = bytes.length) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.bytes = bytes;
    this.at = at;
    this.end = end;
  }

  need(n, field) {
    if (this.at + n > this.end) {
      throw new DecodeError(field, this.at, `needs ${n} byte(s), ${this.end - this.at} left`);
    }
    const at = this.at;
    this.at += n;
    return at;
  }

  u8(field) {
    return this.bytes[this.need(1, field)];
  }

  u16(field) {
    return this.view.getUint16(this.need(2, field), true);
  }

  u32(field) {
    return this.view.getUint32(this.need(4, field), true);
  }

  /** A u64 as a Number: exact below 2^53 (µs timestamps and sequence numbers are). */
  u64(field) {
    const at = this.need(8, field);
    return this.view.getUint32(at + 4, true) * 2 ** 32 + this.view.getUint32(at, true);
  }

  f32(field) {
    return this.view.getFloat32(this.need(4, field), true);
  }

  f64(field) {
    return this.view.getFloat64(this.need(8, field), true);
  }

  /** A reader over the next `n` bytes, which this one steps over. */
  take(n, field) {
    const at = this.need(n, field);
    return new Reader(this.bytes, at, at + n);
  }

  /** The 4-byte magic, which must be one of `expected`; returns it. */
  magic(...expected) {
    const at = this.need(4, "magic");
    const found = String.fromCharCode(...this.bytes.subarray(at, at + 4));
    if (!expected.includes(found)) {
      const names = expected.map((e) => JSON.stringify(e)).join(" or ");
      throw new DecodeError("magic", at, `found ${JSON.stringify(found)}, expected ${names}`);
    }
    return found;
  }

  /** LEB128, at most 10 bytes; the value must stay below `limit`. */
  varint(field, limit) {
    const start = this.at;
    let value = 0;
    let scale = 1;
    for (let i = 0; i < 10; i++) {
      const b = this.u8(field);
      value += (b & 0x7f) * scale;
      if ((b & 0x80) === 0) {
        if (value > limit) {
          throw new DecodeError(field, start, "value out of range");
        }
        return value;
      }
      scale *= 128;
    }
    throw new DecodeError(field, start, "varint longer than 10 bytes");
  }

  finish() {
    if (this.at !== this.end) {
      throw new DecodeError("end", this.at, `${this.end - this.at} unexpected byte(s) after the message`);
    }
  }
}

function unzigzag(value) {
  return value % 2 === 0 ? value / 2 : -(value + 1) / 2;
}

/**
 * Parses `mesh.bin`: "FWM1", u32 vertex count, u32 triangle count, f32 mm per unit,
 * positions (3 x f32), triangles (3 x u32); little-endian.
 */
export function parseMesh(buffer) {
  const r = new Reader(new Uint8Array(buffer));
  r.magic(MESH_MAGIC);
  const vertexCount = r.u32("vertex count");
  const triangleCount = r.u32("triangle count");
  const mmPerUnit = r.f32("mm per unit");
  const expected = 16 + vertexCount * 12 + triangleCount * 12;
  if (buffer.byteLength !== expected) {
    const problem = `${vertexCount} vertices and ${triangleCount} triangles need ${expected} bytes`;
    throw new DecodeError("length", 4, `${problem}, got ${buffer.byteLength}`);
  }
  const positions = new Float32Array(vertexCount * 3);
  for (let i = 0; i < positions.length; i++) {
    positions[i] = r.f32("positions");
  }
  const indices = new Uint32Array(triangleCount * 3);
  for (let i = 0; i < indices.length; i++) {
    const at = r.at;
    indices[i] = r.u32("triangles");
    if (indices[i] >= vertexCount) {
      throw new DecodeError("triangles", at, `vertex ${indices[i]} is out of range (${vertexCount} vertices)`);
    }
  }
  return { vertexCount, triangleCount, mmPerUnit, positions, indices };
}

/**
 * Parses `uv.bin` (FWU1): u32 coordinate count C, u32 triangle count T (the rest mesh's,
 * `triangleCount`), C x (u, v) f32, then T x 3 u32 coordinate indices, one per triangle
 * corner. Returns `{ coords, corners }` (a Float32Array of 2C, a Uint32Array of 3T).
 */
export function parseTextureCoords(buffer, triangleCount) {
  const r = new Reader(new Uint8Array(buffer));
  r.magic(TEXTURE_COORDS_MAGIC);
  const count = r.u32("coordinate count");
  const triangles = r.u32("triangle count");
  const expected = 12 + count * 8 + triangles * 12;
  if (buffer.byteLength !== expected) {
    const problem = `${count} coordinates and ${triangles} triangles need ${expected} bytes`;
    throw new DecodeError("coordinate count", 4, `${problem}, got ${buffer.byteLength}`);
  }
  if (triangles !== triangleCount) {
    throw new DecodeError("triangle count", 8, `${triangles} triangles for a rest mesh of ${triangleCount}`);
  }
  const coords = new Float32Array(count * 2);
  for (let i = 0; i < coords.length; i++) {
    coords[i] = r.f32("coordinates");
  }
  const corners = new Uint32Array(triangles * 3);
  for (let i = 0; i < corners.length; i++) {
    const at = r.at;
    corners[i] = r.u32("corners");
    if (corners[i] >= count) {
      throw new DecodeError("corners", at, `coordinate ${corners[i]} is out of range (${count} coordinates)`);
    }
  }
  return { coords, corners };
}

/**
 * `lips.bin` or a tongue part's `tongue.bin` (FWL1): how much each vertex of a mesh is lip
 * (or tongue), 0 to 1, as a Float32Array (one per vertex). `vertexCount`: the mesh's, which
 * the weights must match.
 */
export function parseVertexWeights(buffer, vertexCount) {
  const r = new Reader(new Uint8Array(buffer));
  r.magic(VERTEX_WEIGHTS_MAGIC);
  const count = r.u32("vertex count");
  if (buffer.byteLength !== 8 + count) {
    throw new DecodeError("vertex count", 4, `${count} vertices need ${8 + count} bytes, got ${buffer.byteLength}`);
  }
  if (count !== vertexCount) {
    throw new DecodeError("vertex count", 4, `${count} weights for a rest mesh of ${vertexCount} vertices`);
  }
  const weights = new Float32Array(count);
  for (let i = 0; i < count; i++) {
    weights[i] = r.u8("weights") / 255;
  }
  return weights;
}

/** seq, producer_time_s, server_receive_us, server_send_us: both layouts' timing fields. */
function readTiming(r) {
  return {
    seq: r.u64("seq"),
    producerTimeS: r.f64("producer_time_s"),
    serverReceiveUs: r.u64("server_receive_us"),
    serverSendUs: r.u64("server_send_us"),
  };
}

/** The lip roughness summary: min, max, mean (3 x f32). */
function readLipSummary(r) {
  return { min: r.f32("lip min"), max: r.f32("lip max"), mean: r.f32("lip mean") };
}

/** FWF1's fixed-size fields after the magic: `[flags, header]`. */
function readFwf1Header(r) {
  const flags = r.u8("flags");
  r.need(3, "reserved");
  const header = {
    ...readTiming(r),
    step: r.f32("step"),
    vertexCount: r.u32("vertex_count"),
    moved: r.u32("moved"),
    lip: readLipSummary(r),
  };
  return [flags, header];
}

/**
 * FWF2's sections after the header: `{bodies, repeated}`, a reader over each known
 * kind's body by name and lists of the `part_deltas` and `eye_motion` bodies; kinds it
 * does not know are skipped. Refuses (naming the field as the Rust decoder does) a count of more sections
 * than the message holds and a section past the end of the message (`section`), a kind
 * given twice (its name), bytes after the last section (`end`), and a frame without
 * `deltas` or `lip_roughness`.
 */
/**
 * The sections after a message's fixed header: `{bodies, repeated}`, readers over each
 * known kind's body by name (`names`: kind to name; unknown kinds are skipped). A frame's
 * part_deltas and eye_motion may repeat (`repeated`: name to a list of bodies); every
 * other kind is refused if given twice, and each of `required` must be there.
 */
function readSections(r, names = SECTION_NAMES, required = ["deltas", "lip_roughness"], what = "frame") {
  const countAt = r.at;
  const count = r.u8("section count");
  const bodies = new Map();
  const repeated = new Map([...REPEATED_SECTIONS].map((name) => [name, []]));
  for (let i = 0; i < count; i++) {
    const at = r.at;
    if (at === r.end) {
      throw new DecodeError("section", at, `${count} sections, the message ends after ${i}`);
    }
    const kind = r.u8("section");
    const length = r.u32("section");
    if (length > r.end - r.at) {
      throw new DecodeError("section", at, `section of kind ${kind} claims ${length} bytes, ${r.end - r.at} are left`);
    }
    const body = r.take(length, "section");
    const name = names.get(kind);
    if (repeated.has(name)) {
      repeated.get(name).push(body);
    } else if (name !== undefined) {
      if (bodies.has(name)) {
        throw new DecodeError(name, at, `section ${name} (kind ${kind}) given twice`);
      }
      body.sectionAt = at;
      bodies.set(name, body);
    }
  }
  r.finish();
  for (const name of required) {
    if (!bodies.has(name)) {
      throw new DecodeError(name, countAt, `the ${what} has no ${name} section`);
    }
  }
  return { bodies, repeated, countAt };
}

/**
 * Decodes an audio chunk ("FWA1"): `{t, serverReceiveUs, codec, sampleRate, samples}` for
 * PCM (an Int16Array, mono) or `{..., codec: "opus", sampleRate: 48000, packet}` (a
 * Uint8Array, one Opus packet). `t` is the stream time of its first sample, seconds: the
 * clock of the frames' producerTimeS.
 */
export function decodeAudio(buffer) {
  const r = new Reader(new Uint8Array(buffer));
  r.magic(AUDIO_MAGIC);
  const t = r.f64("t_s");
  if (!Number.isFinite(t)) {
    throw new DecodeError("t_s", 4, `${t} is not a time`);
  }
  const serverReceiveUs = r.u64("server_receive_us");
  const { bodies, countAt } = readSections(r, AUDIO_SECTION_NAMES, [], "chunk");
  if (bodies.size !== 1) {
    const problem = bodies.size === 0 ? "the chunk has neither a pcm nor an opus section" : "a chunk carries one of pcm and opus, not both";
    throw new DecodeError("sound", bodies.size === 0 ? countAt : bodies.get("opus").sectionAt, problem);
  }
  const [[codec, body]] = [...bodies];
  if (codec === "pcm") {
    const rateAt = body.at;
    const sampleRate = body.u32("sample_rate");
    if (!PCM_RATES.includes(sampleRate)) {
      throw new DecodeError("sample_rate", rateAt, `${sampleRate} Hz: expected 16000, 24000 or 48000`);
    }
    const count = body.u32("pcm count");
    const start = body.need(count * 2, "pcm");
    const samples = new Int16Array(count);
    for (let i = 0; i < count; i++) {
      samples[i] = body.view.getInt16(start + 2 * i, true);
    }
    return { t, serverReceiveUs, codec, sampleRate, samples };
  }
  const length = body.u16("opus length");
  if (length === 0 || length > MAX_OPUS_PACKET) {
    throw new DecodeError("opus", body.at, `${length} bytes: an Opus packet has 1 to ${MAX_OPUS_PACKET}`);
  }
  const start = body.need(length, "opus");
  return { t, serverReceiveUs, codec, sampleRate: OPUS_RATE, packet: body.bytes.slice(start, start + length) };
}

/**
 * A `deltas` or `part_deltas` body's step, vertex_count and moved (refused above
 * vertex_count as `movedField`): `{step, vertexCount, moved, movedAt}`.
 */
function readBlockCounts(body, movedField) {
  const step = body.f32("step");
  const vertexCount = body.u32("vertex_count");
  const movedAt = body.at;
  const moved = body.u32(movedField);
  if (moved > vertexCount) {
    throw new DecodeError(movedField, movedAt, `${moved} moved of ${vertexCount} vertices`);
  }
  return { step, vertexCount, moved, movedAt };
}

/**
 * FWF2's header and sections after the magic: `{header, sections, counts}`, the header
 * shaped as FWF1's (its step, counts and lip summary from the `deltas` and
 * `lip_roughness` sections, whose readers are left after those fields), `counts` the
 * head's readBlockCounts.
 */
function readFwf2Header(r) {
  const timing = readTiming(r);
  const sections = readSections(r);
  const counts = readBlockCounts(sections.bodies.get("deltas"), "moved");
  const { step, vertexCount, moved } = counts;
  const lip = readLipSummary(sections.bodies.get("lip_roughness"));
  return { header: { ...timing, step, vertexCount, moved, lip }, sections, counts };
}

/**
 * The fixed-size part of a frame (timing, sequence, step and counts, lip roughness
 * summary), without walking the deltas: cheap enough for every frame that arrives, drawn
 * or skipped. For FWF2 it steps over the sections to find them.
 */
export function readFrameHeader(buffer) {
  const r = new Reader(new Uint8Array(buffer));
  return r.magic(FWF2_MAGIC, FWF1_MAGIC) === FWF2_MAGIC ? readFwf2Header(r).header : readFwf1Header(r)[1];
}

/** Raw-deflated (RFC 1951) bytes, inflated natively; more than `limit` bytes is an error. */
async function inflateRaw(bytes, limit, at) {
  const reader = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate-raw")).getReader();
  const chunks = [];
  let length = 0;
  try {
    for (;;) {
      const { done, value } = await reader.read();
      if (done) {
        break;
      }
      length += value.length;
      if (length > limit) {
        reader.cancel().catch(() => {});
        throw new DecodeError("delta block", at, `inflates past ${limit} bytes`);
      }
      chunks.push(value);
    }
  } catch (e) {
    throw e instanceof DecodeError ? e : new DecodeError("delta block", at, `bad deflate data: ${e.message}`);
  }
  const out = new Uint8Array(length);
  let offset = 0;
  for (const chunk of chunks) {
    out.set(chunk, offset);
    offset += chunk.length;
  }
  return out;
}

/** A rigid motion: 7 x f32, finite, with a unit rotation quaternion. */
function readRigidMotion(r, field) {
  const at = r.at;
  const values = [];
  for (let i = 0; i < 7; i++) {
    values.push(r.f32(field));
  }
  if (!values.every(Number.isFinite)) {
    throw new DecodeError(field, at, `not finite: ${values.join(", ")}`);
  }
  const rotation = values.slice(0, 4);
  const length = Math.hypot(...rotation);
  if (Math.abs(length - 1) > UNIT_QUATERNION_TOLERANCE) {
    throw new DecodeError(field, at, `rotation quaternion of length ${length}, not 1`);
  }
  return { rotation, translation: values.slice(4) };
}

/**
 * The lip region's folds (8 bytes): u16 lip triangles turned over 60 degrees, u16 over
 * 90, f32 the largest dihedral increase over rest in degrees (finite, not negative).
 */
function readLipFolds(r) {
  const turnedOver60 = r.u16("lip folds");
  const turnedOver90 = r.u16("lip folds");
  const at = r.at;
  const maxDihedralIncreaseDeg = r.f32("lip folds");
  if (!(Number.isFinite(maxDihedralIncreaseDeg) && maxDihedralIncreaseDeg >= 0)) {
    throw new DecodeError("lip folds", at, `largest dihedral increase ${maxDihedralIncreaseDeg}`);
  }
  return { turnedOver60, turnedOver90, maxDihedralIncreaseDeg };
}

/** The mean roughness around each lip vertex: n (u8), then n x f32. */
function readLipValues(r) {
  const count = r.u8("lip_count");
  const values = new Float32Array(count);
  for (let i = 0; i < count; i++) {
    values[i] = r.f32("lip roughness");
  }
  return values;
}

/** The label: length (u8), then that many bytes of UTF-8. */
function readLabel(r) {
  const length = r.u8("label length");
  const at = r.need(length, "label");
  try {
    return new TextDecoder("utf-8", { fatal: true }).decode(r.bytes.subarray(at, at + length));
  } catch {
    throw new DecodeError("label", at, "not UTF-8");
  }
}

/** `count` per-vertex bytes (the field `field`) as values: byte / 255 x max. */
function readPerVertex(r, max, count, field) {
  const at = r.need(count, field);
  const values = new Float32Array(count);
  for (let v = 0; v < count; v++) {
    values[v] = Math.fround(r.bytes[at + v] / 255) * max;
  }
  return values;
}

/**
 * Decodes a whole frame, FWF2 or FWF1 by its magic (a promise: a deflated delta block
 * inflates asynchronously). `movedIndices[i]` is a vertex and `movedCounts[3i..3i+3]` its
 * quantized delta: delta = counts x step, head units. `face` is the per-vertex values
 * (Float32Array: the snapshot's `heat`, face roughness or folds) or null, and `faceMax`
 * their max as sent (null without them); `label` a string or null, `head` the head's rigid
 * motion ({rotation: quaternion x, y, z, w; translation: head units}) and `jaw` the jaw's
 * (applied before the head's to the parts that move with it), each AT_REST when the frame
 * has none. `parts` lists the part deltas in part order, each `{part, step, vertexCount,
 * movedIndices, movedCounts}`: `part` its index in the snapshot's `parts`, the counts of
 * that part's vertices with its `step`, applied before the jaw's and the head's motions;
 * `tongue` is its first entry (the tongue: the only part the server shapes), or null (the
 * tongue at rest). `folds` is null (not measured) or the lip region's folds after its own
 * rigid motion, `{turnedOver60, turnedOver90, maxDihedralIncreaseDeg}`: lip triangles
 * whose normal turned more than 60 and more than 90 degrees from rest, and the largest
 * increase of a dihedral angle between two lip triangles over rest (degrees). `eyes` lists
 * the turned eyeballs, each `{eye, motion}`: `eye` its index in the snapshot's `eyes`,
 * `motion` its turn about its centre (as `head`), applied before the head's motion; eyes
 * not listed look ahead (FWF1 frames list none). `viseme` is the mouth shape that drove the
 * frame, `{select1, select2, blend}` (MPEG-4 FAP 1), or null (none named; FWF1 frames).
 */
export async function decodeFrame(buffer) {
  const r = new Reader(new Uint8Array(buffer));
  const frame = r.magic(FWF2_MAGIC, FWF1_MAGIC) === FWF2_MAGIC ? await decodeFwf2(r) : await decodeFwf1(r);
  return { ...frame, tongue: frame.parts[0] ?? null };
}

/** An FWF1 frame after its magic, as decodeFrame describes it (all but `tongue`). */
async function decodeFwf1(r) {
  const [flags, header] = readFwf1Header(r);
  const { vertexCount, moved } = header;
  const perVertex = readLipValues(r);
  const label = flags & FLAG_LABEL ? readLabel(r) : null;
  const head = flags & FLAG_HEAD ? readRigidMotion(r, "head motion") : AT_REST;
  const jaw = flags & FLAG_JAW ? readRigidMotion(r, "jaw motion") : AT_REST;
  const folds = flags & FLAG_FOLDS ? readLipFolds(r) : null;
  if (moved > vertexCount) {
    throw new DecodeError("moved", 48, `${moved} moved of ${vertexCount} vertices`);
  }
  const deflated = (flags & FLAG_DEFLATE) !== 0;
  const { movedIndices, movedCounts } = await readDeltas(r, deflated, moved, vertexCount, FWF1_MOVED);
  const parts = [];
  if (flags & FLAG_TONGUE) {
    const part = r.u8("tongue part");
    const tongueVertices = r.u32("tongue vertex_count");
    const movedAt = r.at;
    const tongueMoved = r.u32("tongue moved");
    if (tongueMoved > tongueVertices) {
      throw new DecodeError("tongue moved", movedAt, `${tongueMoved} moved of ${tongueVertices} vertices`);
    }
    const deltas = await readDeltas(r, deflated, tongueMoved, tongueVertices, FWF1_MOVED);
    parts.push({ part, step: header.step, vertexCount: tongueVertices, ...deltas });
  }
  let face = null;
  let faceMax = null;
  if (flags & FLAG_FACE) {
    faceMax = r.f32("heat max");
    face = readPerVertex(r, faceMax, vertexCount, "heat");
  }
  r.finish();
  const lip = { ...header.lip, perVertex };
  return {
    ...header, lip, label, head, jaw, movedIndices, movedCounts, parts, folds, eyes: [], viseme: null, face, faceMax,
  };
}

/**
 * An FWF2 frame after its magic, as decodeFrame describes it (all but `tongue`). Sections may
 * come in any order; every known one is read as far as its documented fields go, the rest
 * of its body being fields from a later server.
 */
async function decodeFwf2(r) {
  const { header, sections, counts } = readFwf2Header(r);
  const { bodies, repeated } = sections;
  const section = (name, read, absent) => (bodies.has(name) ? read(bodies.get(name)) : absent);
  const perVertex = readLipValues(bodies.get("lip_roughness"));
  const label = section("label", readLabel, null);
  const head = section("head_motion", (body) => readRigidMotion(body, "head motion"), AT_REST);
  const jaw = section("jaw_motion", (body) => readRigidMotion(body, "jaw motion"), AT_REST);
  const folds = section("lip_folds", readLipFolds, null);
  const { movedIndices, movedCounts } = await readEncodedDeltas(bodies.get("deltas"), counts, "moved");
  const parts = await readPartDeltas(repeated.get("part_deltas"));
  const eyes = readEyeMotions(repeated.get("eye_motion"));
  const viseme = section("viseme", readViseme, null);
  const heat = section("heat", (body) => readHeat(body, header.vertexCount), { face: null, faceMax: null });
  const lip = { ...header.lip, perVertex };
  return { ...header, lip, label, head, jaw, movedIndices, movedCounts, parts, folds, eyes, viseme, ...heat };
}

/**
 * A `viseme` body: the frame's MPEG-4 FAP 1, `{select1, select2, blend}` (visemes 0-14 in
 * the Oculus order, blend 0-63 the share of `select1`).
 */
function readViseme(r) {
  const at = r.at;
  const viseme = { select1: r.u8("viseme"), select2: r.u8("viseme"), blend: r.u8("viseme") };
  if (viseme.select1 > 14 || viseme.select2 > 14 || viseme.blend > 63) {
    throw new DecodeError(
      "viseme",
      at,
      `selects ${viseme.select1} and ${viseme.select2}, blend ${viseme.blend}: expected visemes 0-14 and a blend of 0-63`,
    );
  }
  return viseme;
}

/**
 * `eye_motion` bodies, each an eye at most once: decodeFrame's `eyes`, in eye order, each
 * `{eye, motion}` (`eye` its index in the snapshot's `eyes`, `motion` as `head`).
 */
function readEyeMotions(bodies) {
  const eyes = [];
  for (const body of bodies) {
    const at = body.at;
    const eye = body.u8("eye");
    if (eyes.some((e) => e.eye === eye)) {
      throw new DecodeError("eye_motion", at, `eye ${eye} given twice`);
    }
    eyes.push({ eye, motion: readRigidMotion(body, "eye motion") });
  }
  return eyes.sort((a, b) => a.eye - b.eye);
}

/** `part_deltas` bodies, each a part at most once: decodeFrame's `parts`, in part order. */
async function readPartDeltas(bodies) {
  const parts = [];
  for (const body of bodies) {
    const at = body.at;
    const part = body.u8("part");
    if (parts.some((p) => p.part === part)) {
      throw new DecodeError("part_deltas", at, `part ${part} given twice`);
    }
    const counts = readBlockCounts(body, "part moved");
    const deltas = await readEncodedDeltas(body, counts, "part moved");
    parts.push({ part, step: counts.step, vertexCount: counts.vertexCount, ...deltas });
  }
  return parts.sort((a, b) => a.part - b.part);
}

/**
 * The rest of a `deltas` or `part_deltas` body after readBlockCounts: encoding (0 plain,
 * 1 raw deflate), then the delta block.
 */
function readEncodedDeltas(body, counts, movedField) {
  const at = body.at;
  const encoding = body.u8("encoding");
  if (encoding !== ENCODING_PLAIN && encoding !== ENCODING_DEFLATE) {
    throw new DecodeError("encoding", at, `${encoding}: expected 0 (plain) or 1 (raw deflate)`);
  }
  const moved = { field: movedField, at: counts.movedAt };
  return readDeltas(body, encoding === ENCODING_DEFLATE, counts.moved, counts.vertexCount, moved);
}

/** A `heat` body: max (f32), count (u32, the head's vertex count), count bytes. */
function readHeat(body, vertexCount) {
  const faceMax = body.f32("heat max");
  const at = body.at;
  const count = body.u32("heat count");
  if (count !== vertexCount) {
    throw new DecodeError("heat count", at, `${count} values for ${vertexCount} vertices`);
  }
  return { face: readPerVertex(body, faceMax, count, "heat"), faceMax };
}

/**
 * A delta block's length and the block (the head's or a part's), inflated first when
 * `deflated`: `{movedIndices, movedCounts}` of `moved` entries, each a vertex below
 * `vertexCount`, the count named by `movedField` as readDeltaBlock says.
 */
async function readDeltas(r, deflated, moved, vertexCount, movedField) {
  const blockLength = r.u32("delta block length");
  const blockAt = r.need(blockLength, "delta block");
  const stored = r.bytes.subarray(blockAt, blockAt + blockLength);
  // An entry takes 4 to 40 bytes: never inflate past what the count allows.
  const block = deflated ? await inflateRaw(stored, moved * 40, blockAt) : stored;
  return readDeltaBlock(block, blockAt, moved, vertexCount, movedField);
}

/**
 * The delta block: `moved` x { varint index gap, 3 x zigzag varint count differences
 * from the previous moved vertex }. Error offsets are those of the stored block;
 * `movedField` ({field, at}) names the count when the block is too short for it.
 */
function readDeltaBlock(block, blockAt, moved, vertexCount, movedField) {
  if (moved > block.length / 4) {
    throw new DecodeError(movedField.field, movedField.at, `${moved} entries cannot fit in ${block.length} bytes`);
  }
  const r = new Reader(block);
  const movedIndices = new Uint32Array(moved);
  const movedCounts = new Int32Array(moved * 3);
  let previous = -1;
  const previousCounts = [0, 0, 0];
  for (let i = 0; i < moved; i++) {
    const at = blockAt + r.at;
    const index = previous + 1 + r.varint("index gap", vertexCount);
    if (index >= vertexCount) {
      throw new DecodeError("index gap", at, `vertex ${index} is out of range (${vertexCount} vertices)`);
    }
    movedIndices[i] = index;
    for (let k = 0; k < 3; k++) {
      const at = blockAt + r.at;
      const count = previousCounts[k] + unzigzag(r.varint("delta", MAX_DIFFERENCE));
      if (count < I32_MIN || count > I32_MAX) {
        throw new DecodeError("delta", at, "count out of range");
      }
      movedCounts[i * 3 + k] = count;
      previousCounts[k] = count;
    }
    previous = index;
  }
  if (r.at !== block.length) {
    throw new DecodeError("delta block", blockAt, `${block.length - r.at} byte(s) left after ${moved} entries`);
  }
  return { movedIndices, movedCounts };
}

/**
 * A rigid motion as a column-major 4x4 matrix (WebGL's order): rotation, then
 * translation.
 */
export function motionMatrix({ rotation: [x, y, z, w], translation: [tx, ty, tz] }) {
  return new Float32Array([
    1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y), 0,
    2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x), 0,
    2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y), 0,
    tx, ty, tz, 1,
  ]);
}

/**
 * Rest positions plus the frame's deltas into `out` (flat xyz, head units), in f32 steps
 * like the Rust client (`ViewerFrame::apply`): out = rest + f32(counts) x step.
 */
export function applyFrame(rest, frame, out) {
  return applyDeltas(rest, frame, frame.step, out);
}

/**
 * Rest positions plus decoded deltas (`{movedIndices, movedCounts}`: a frame, or one of
 * its `parts` with that part's rest and `step`) into `out`, as applyFrame: out = rest +
 * f32(counts) x step. Allocates nothing.
 */
export function applyDeltas(rest, { movedIndices, movedCounts }, step, out) {
  out.set(rest);
  for (let i = 0; i < movedIndices.length; i++) {
    const base = movedIndices[i] * 3;
    for (let k = 0; k < 3; k++) {
      out[base + k] += Math.fround(Math.fround(movedCounts[i * 3 + k]) * step);
    }
  }
  return out;
}
