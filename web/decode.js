// decode.js: reads the server's two binary formats into typed arrays: the rest mesh
// (`mesh.bin`, "FWM1") and the viewer frame ("FWF1", proto/src/frame.rs). It touches no DOM,
// so node runs it in tests/web_decode.rs against frames from the server's own encoder.
// Every length is checked: a bad message throws a DecodeError naming the field and byte.
// A deflated delta block is inflated by the browser's own DecompressionStream, which is
// why decodeFrame returns a promise.

const MESH_MAGIC = "FWM1";
const FRAME_MAGIC = "FWF1";
const FLAG_FACE = 1;
const FLAG_LABEL = 2;
const FLAG_DEFLATE = 4;
const FLAG_HEAD = 8;
const FLAG_JAW = 16;
const FLAG_TONGUE = 32;
const FLAG_FOLDS = 64;
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

/** Little-endian reader over a Uint8Array that names the field on every short read. */
class Reader {
  constructor(bytes) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    this.bytes = bytes;
    this.at = 0;
  }

  need(n, field) {
    if (this.at + n > this.bytes.length) {
      throw new DecodeError(field, this.at, `needs ${n} byte(s), the message has ${this.bytes.length - this.at} left`);
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

  magic(expected) {
    const at = this.need(4, "magic");
    const found = String.fromCharCode(...this.bytes.subarray(at, at + 4));
    if (found !== expected) {
      throw new DecodeError("magic", at, `found ${JSON.stringify(found)}, expected ${JSON.stringify(expected)}`);
    }
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
    if (this.at !== this.bytes.length) {
      throw new DecodeError("end", this.at, `${this.bytes.length - this.at} unexpected byte(s) after the message`);
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

/** The fixed-size fields: `[flags, header]`. */
function readHeaderFields(r) {
  r.magic(FRAME_MAGIC);
  const flags = r.u8("flags");
  r.need(3, "reserved");
  const header = {
    seq: r.u64("seq"),
    producerTimeS: r.f64("producer_time_s"),
    serverReceiveUs: r.u64("server_receive_us"),
    serverSendUs: r.u64("server_send_us"),
    step: r.f32("step"),
    vertexCount: r.u32("vertex_count"),
    moved: r.u32("moved"),
    lip: { min: r.f32("lip min"), max: r.f32("lip max"), mean: r.f32("lip mean") },
  };
  return [flags, header];
}

/**
 * The fixed-size part of a frame (timing, sequence, lip roughness summary), without
 * walking the deltas: cheap enough for every frame that arrives, drawn or skipped.
 */
export function readFrameHeader(buffer) {
  return readHeaderFields(new Reader(new Uint8Array(buffer)))[1];
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

/**
 * Decodes a whole frame (a promise: a deflated delta block inflates asynchronously).
 * `movedIndices[i]` is a vertex and `movedCounts[3i..3i+3]` its quantized delta:
 * delta = counts x step, head units. `face` is per-vertex roughness (Float32Array) or
 * null, `label` a string or null, `head` the head's rigid motion ({rotation: quaternion
 * x, y, z, w; translation: head units}) and `jaw` the jaw's (applied before the head's to
 * the parts that move with it), each AT_REST when the frame has none. `tongue` is null
 * (the tongue at rest) or the tongue's deltas, `{part, vertexCount, movedIndices,
 * movedCounts}`: `part` its index in the snapshot's `parts`, the counts of that part's
 * vertices with the frame's `step`, applied before the jaw's and the head's motions.
 * `folds` is null (not measured) or the lip region's folds after its own rigid motion,
 * `{turnedOver60, turnedOver90, maxDihedralIncreaseDeg}`: lip triangles whose normal
 * turned more than 60 and more than 90 degrees from rest, and the largest increase of a
 * dihedral angle between two lip triangles over rest (degrees).
 */
export async function decodeFrame(buffer) {
  const r = new Reader(new Uint8Array(buffer));
  const [flags, header] = readHeaderFields(r);
  const { vertexCount, moved } = header;
  const lipCount = r.u8("lip_count");
  const lipPerVertex = new Float32Array(lipCount);
  for (let i = 0; i < lipCount; i++) {
    lipPerVertex[i] = r.f32("lip roughness");
  }
  let label = null;
  if (flags & FLAG_LABEL) {
    const length = r.u8("label length");
    const at = r.need(length, "label");
    try {
      label = new TextDecoder("utf-8", { fatal: true }).decode(r.bytes.subarray(at, at + length));
    } catch {
      throw new DecodeError("label", at, "not UTF-8");
    }
  }
  const head = flags & FLAG_HEAD ? readRigidMotion(r, "head motion") : AT_REST;
  const jaw = flags & FLAG_JAW ? readRigidMotion(r, "jaw motion") : AT_REST;
  const folds = flags & FLAG_FOLDS ? readLipFolds(r) : null;
  if (moved > vertexCount) {
    throw new DecodeError("moved", 48, `${moved} moved of ${vertexCount} vertices`);
  }
  const deflated = (flags & FLAG_DEFLATE) !== 0;
  const { movedIndices, movedCounts } = await readDeltas(r, deflated, moved, vertexCount);
  let tongue = null;
  if (flags & FLAG_TONGUE) {
    const part = r.u8("tongue part");
    const tongueVertices = r.u32("tongue vertex_count");
    const movedAt = r.at;
    const tongueMoved = r.u32("tongue moved");
    if (tongueMoved > tongueVertices) {
      throw new DecodeError("tongue moved", movedAt, `${tongueMoved} moved of ${tongueVertices} vertices`);
    }
    const deltas = await readDeltas(r, deflated, tongueMoved, tongueVertices);
    tongue = { part, vertexCount: tongueVertices, ...deltas };
  }
  let face = null;
  if (flags & FLAG_FACE) {
    const max = r.f32("face roughness max");
    const at = r.need(vertexCount, "face roughness");
    face = new Float32Array(vertexCount);
    for (let v = 0; v < vertexCount; v++) {
      face[v] = Math.fround(r.bytes[at + v] / 255) * max;
    }
  }
  r.finish();
  return {
    ...header,
    lip: { ...header.lip, perVertex: lipPerVertex },
    label,
    head,
    jaw,
    movedIndices,
    movedCounts,
    tongue,
    folds,
    face,
  };
}

/**
 * A delta block's length and the block (the head's or the tongue's), inflated first
 * when `deflated`: `{movedIndices, movedCounts}` of `moved` entries, each a vertex below
 * `vertexCount`.
 */
async function readDeltas(r, deflated, moved, vertexCount) {
  const blockLength = r.u32("delta block length");
  const blockAt = r.need(blockLength, "delta block");
  const stored = r.bytes.subarray(blockAt, blockAt + blockLength);
  // An entry takes 4 to 40 bytes: never inflate past what the count allows.
  const block = deflated ? await inflateRaw(stored, moved * 40, blockAt) : stored;
  return readDeltaBlock(block, blockAt, moved, vertexCount);
}

/**
 * The delta block: `moved` x { varint index gap, 3 x zigzag varint count differences
 * from the previous moved vertex }. Error offsets are those of the stored block.
 */
function readDeltaBlock(block, blockAt, moved, vertexCount) {
  if (moved > block.length / 4) {
    throw new DecodeError("moved", 48, `${moved} entries cannot fit in ${block.length} bytes`);
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
 * Rest positions plus decoded deltas (`{movedIndices, movedCounts}`: a frame, or its
 * `tongue` with the tongue's rest) into `out`, as applyFrame: out = rest + f32(counts) x
 * step. Allocates nothing.
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
