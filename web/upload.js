// upload.js: a head of the user's own, registered from the page. The user picks the files
// (a glTF avatar: a `.glb`, or a `.gltf` with the buffers and images it names beside it;
// or an `.obj` with, optionally, its texture image), names the head, and the server fits
// it (the automatic fit: no landmarks needed); the page follows the registration's
// progress, then shows the head and its fit report. The request is what
// proto/PROTOCOL.md describes for `POST /v1/heads` (JSON with the OBJ text and the image
// in base64, or a `.glb`'s bytes with `?id=`): a glTF whose buffers or images are files
// of their own (as "glTF Separate" exports write them) is packed into one `.glb` here
// first, since the server takes one file. The files go to the facewire server and nowhere
// else. The request is built by pure functions (node tests them: upload.test.mjs).

/** How often a registering head's state is read, ms. */
const POLL_MS = 500;
/** How long a registration is followed before the page gives up saying so, ms. */
const FOLLOW_MS = 300_000;
/** The image types the server draws as a texture. */
const IMAGE_TYPES = { png: "image/png", jpg: "image/jpeg", jpeg: "image/jpeg" };

/** The file name's extension, lowercase, without the dot ("" for none). */
function extension(name) {
  const dot = name.lastIndexOf(".");
  return dot < 0 ? "" : name.slice(dot + 1).toLowerCase();
}

/**
 * A head id from a file name, as the server takes ids (lowercase letters, digits, `-` and
 * `_`, 1 to 64): `My Head (2).glb` gives `my-head-2`; `head` when nothing is left.
 */
export function idFromFileName(name) {
  const stem = name.replace(/\.[^.]*$/, "").toLowerCase();
  const id = stem
    .replace(/[^a-z0-9_-]+/g, "-")
    .replace(/^-+|-+$/g, "")
    .slice(0, 64)
    .replace(/-+$/, "");
  return id || "head";
}

/** Whether `id` is one the server takes. */
export function validId(id) {
  return /^[a-z0-9_-]{1,64}$/.test(id);
}

/**
 * What to send for `files` (objects with `name`): `{ kind: "gltf", file, others }` for a
 * `.glb` or `.gltf` (`others`: the `.bin` and image files picked with it, for what it
 * names by URI), or `{ kind: "obj", obj, image }` for an `.obj` and at most one PNG or
 * JPEG image (a `.mtl` is accepted and not needed); the files are not read yet. Throws
 * an Error that says what is missing or too much, naming the files.
 */
export function chooseFiles(files) {
  const by = (exts) => files.filter((f) => exts.includes(extension(f.name)));
  const gltfs = by(["glb", "gltf"]);
  const objs = by(["obj"]);
  const images = by(Object.keys(IMAGE_TYPES));
  const bins = by(["bin"]);
  const known = ["glb", "gltf", "bin", "obj", "mtl", ...Object.keys(IMAGE_TYPES)];
  const others = files.filter((f) => !known.includes(extension(f.name)));
  if (others.length > 0) {
    throw new Error(`${others.map((f) => f.name).join(", ")}: not a .glb, .gltf, .bin, .obj, .mtl, PNG or JPEG file`);
  }
  if (gltfs.length + objs.length === 0) {
    throw new Error("pick a head: a .glb or .gltf avatar, or an .obj (with its texture image if it has one)");
  }
  if (gltfs.length + objs.length > 1) {
    throw new Error(`one head at a time: ${[...gltfs, ...objs].map((f) => f.name).join(", ")}`);
  }
  if (gltfs.length === 1) {
    return { kind: "gltf", file: gltfs[0], others: [...bins, ...images] };
  }
  if (bins.length > 0) {
    throw new Error(`${bins.map((f) => f.name).join(", ")}: a .bin goes with a .gltf, not an .obj`);
  }
  if (images.length > 1) {
    throw new Error(`one texture image at most: ${images.map((f) => f.name).join(", ")}`);
  }
  return { kind: "obj", obj: objs[0], image: images[0] ?? null };
}

const GLB_MAGIC = 0x46546c67; // "glTF"
const JSON_CHUNK = 0x4e4f534a; // "JSON"
const BIN_CHUNK = 0x004e4942; // "BIN\0"

/** A `.glb`'s JSON and binary chunk (or null), as the glTF 2.0 binary format lays them out. */
export function readGlb(buffer) {
  const view = new DataView(buffer);
  if (buffer.byteLength < 20 || view.getUint32(0, true) !== GLB_MAGIC || view.getUint32(4, true) !== 2) {
    throw new Error("not a glTF 2.0 binary (.glb) file");
  }
  const jsonLength = view.getUint32(12, true);
  if (view.getUint32(16, true) !== JSON_CHUNK || 20 + jsonLength > buffer.byteLength) {
    throw new Error("a .glb whose first chunk is not its JSON");
  }
  const json = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 20, jsonLength)));
  let bin = null;
  const at = 20 + jsonLength;
  if (at + 8 <= buffer.byteLength && view.getUint32(at + 4, true) === BIN_CHUNK) {
    const length = view.getUint32(at, true);
    bin = new Uint8Array(buffer, at + 8, Math.min(length, buffer.byteLength - at - 8));
  }
  return { json, bin };
}

/** `json` and one binary chunk `bin` as a `.glb` (chunks padded to 4 bytes, as the format asks). */
export function writeGlb(json, bin) {
  const text = new TextEncoder().encode(JSON.stringify(json));
  const jsonLength = Math.ceil(text.length / 4) * 4;
  const binLength = bin ? Math.ceil(bin.length / 4) * 4 : 0;
  const total = 12 + 8 + jsonLength + (bin ? 8 + binLength : 0);
  const out = new Uint8Array(total);
  const view = new DataView(out.buffer);
  view.setUint32(0, GLB_MAGIC, true);
  view.setUint32(4, 2, true);
  view.setUint32(8, total, true);
  view.setUint32(12, jsonLength, true);
  view.setUint32(16, JSON_CHUNK, true);
  out.set(text, 20);
  out.fill(0x20, 20 + text.length, 20 + jsonLength);
  if (bin) {
    view.setUint32(20 + jsonLength, binLength, true);
    view.setUint32(24 + jsonLength, BIN_CHUNK, true);
    out.set(bin, 28 + jsonLength);
  }
  return out.buffer;
}

/** The bytes of a `data:` URI (base64 or percent-encoded), and its MIME type. */
function dataUri(uri) {
  const comma = uri.indexOf(",");
  const header = uri.slice(5, comma);
  const body = uri.slice(comma + 1);
  const bytes = header.endsWith(";base64")
    ? Uint8Array.from(atob(body), (c) => c.charCodeAt(0))
    : new TextEncoder().encode(decodeURIComponent(body));
  return { bytes, mime: header.replace(/;base64$/, "") || "application/octet-stream" };
}

/**
 * A glTF with everything it names by URI put inside: `json` (the document, not changed),
 * `bin` (a `.glb`'s own binary chunk, which its first buffer without a URI is, or null),
 * `files`: a map from file name to bytes for what the URIs name (matched by the URI's last
 * path segment, decoded). Returns the `.glb`'s bytes: every buffer laid end to end in one
 * binary chunk (each 4-byte aligned) with the views moved along, and every image behind a
 * URI given a view of its bytes and its MIME type. Throws naming a file that is missing.
 */
export function packGlb(json, bin, files) {
  const doc = structuredClone(json);
  const bytesOf = (uri, what) => {
    if (uri.startsWith("data:")) {
      return dataUri(uri);
    }
    const name = decodeURIComponent(uri.split(/[\\/]/).pop());
    const bytes = files.get(name);
    if (!bytes) {
      throw new Error(`the glTF's ${what} is the file "${name}": pick it too`);
    }
    const mime = IMAGE_TYPES[extension(name)] ?? "application/octet-stream";
    return { bytes, mime };
  };
  const pieces = [];
  let length = 0;
  const append = (bytes) => {
    length = Math.ceil(length / 4) * 4;
    const offset = length;
    pieces.push([offset, bytes]);
    length += bytes.length;
    return offset;
  };
  const starts = (doc.buffers ?? []).map((buffer, i) => {
    if (buffer.uri === undefined) {
      if (!bin) {
        throw new Error(`the glTF's buffer ${i} has no URI and there is no binary chunk`);
      }
      return append(bin.subarray(0, buffer.byteLength));
    }
    return append(bytesOf(buffer.uri, `buffer ${i}`).bytes);
  });
  for (const view of doc.bufferViews ?? []) {
    view.byteOffset = (view.byteOffset ?? 0) + starts[view.buffer];
    view.buffer = 0;
  }
  for (const [i, image] of (doc.images ?? []).entries()) {
    if (image.uri === undefined) {
      continue;
    }
    const { bytes, mime } = bytesOf(image.uri, `image ${i}`);
    doc.bufferViews = doc.bufferViews ?? [];
    doc.bufferViews.push({ buffer: 0, byteOffset: append(bytes), byteLength: bytes.length });
    image.bufferView = doc.bufferViews.length - 1;
    image.mimeType = image.mimeType ?? mime;
    delete image.uri;
  }
  const packed = new Uint8Array(Math.ceil(length / 4) * 4);
  for (const [offset, bytes] of pieces) {
    packed.set(bytes, offset);
  }
  doc.buffers = length > 0 ? [{ byteLength: length }] : [];
  return writeGlb(doc, length > 0 ? packed : null);
}

/**
 * The `.glb` to send for a picked glTF (`chosen` from chooseFiles): a `.glb` whose buffers
 * and images are all inside as it is; anything else packed (packGlb) with the files picked
 * beside it.
 */
export async function glbOf(chosen) {
  const text = extension(chosen.file.name) === "gltf";
  const { json, bin } = text
    ? { json: JSON.parse(await chosen.file.text()), bin: null }
    : readGlb(await chosen.file.arrayBuffer());
  const outside = [...(json.buffers ?? []), ...(json.images ?? [])].some((item) => item.uri !== undefined);
  if (!text && !outside) {
    return chosen.file.arrayBuffer();
  }
  const files = new Map();
  for (const file of chosen.others) {
    files.set(file.name, new Uint8Array(await file.arrayBuffer()));
  }
  return packGlb(json, bin, files);
}

/** Bytes as base64, in pieces (a texture can be megabytes). */
export function base64(bytes) {
  let text = "";
  for (let i = 0; i < bytes.length; i += 0x8000) {
    text += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  }
  return btoa(text);
}

/**
 * The request that registers `chosen` (chooseFiles) as `id`, its files read: `{ path,
 * init }` for fetch. `token`: the admin token, when the server has one.
 */
export async function registrationRequest(chosen, id, token) {
  const headers = token ? { Authorization: `Bearer ${token}` } : {};
  if (chosen.kind === "gltf") {
    return {
      path: `/v1/heads?id=${encodeURIComponent(id)}`,
      init: {
        method: "POST",
        headers: { ...headers, "Content-Type": "model/gltf-binary" },
        body: await glbOf(chosen),
      },
    };
  }
  const body = { id, obj: await chosen.obj.text() };
  if (chosen.image) {
    body.texture = base64(new Uint8Array(await chosen.image.arrayBuffer()));
  }
  return {
    path: "/v1/heads",
    init: { method: "POST", headers: { ...headers, "Content-Type": "application/json" }, body: JSON.stringify(body) },
  };
}

/** The words for a refused registration: the server's `error` message, else the status. */
async function refusal(response) {
  const body = await response.json().catch(() => null);
  const said = body?.message ?? body?.error;
  if (response.status === 401 || response.status === 403) {
    return `the server asks for its admin token (${said ?? response.status})`;
  }
  if (response.status === 413) {
    return "the files are larger than the server takes (its max_upload_bytes)";
  }
  return said ? `${said} (${response.status})` : `HTTP ${response.status}`;
}

/**
 * What a `.glb` became, in words for the page (empty for none): its texture, and the
 * ARKit blendshapes its own morph targets drive, with the targets not taken.
 */
export function sourceSummary(source) {
  if (!source) {
    return "";
  }
  const said = [];
  if (source.texture) {
    said.push(`Texture: ${source.texture}.`);
  }
  const arkit = source.arkit_targets ?? [];
  const leftOut = source.targets_left_out ?? [];
  if (arkit.length > 0) {
    said.push(`ARKit: ${arkit.length} blendshapes from its own morph targets.`);
  }
  if (leftOut.length > 0) {
    const names = leftOut.slice(0, 5).map((t) => t.name).join(", ");
    const more = leftOut.length > 5 ? ` and ${leftOut.length - 5} more` : "";
    said.push(`Morph targets not used: ${names}${more} (${leftOut[0].why}${leftOut.length > 1 ? ", ..." : ""}).`);
  }
  return said.join(" ");
}

/**
 * Registers `files` as `id` on the server (`nodes`: nodes.js) and follows it to the end:
 * `onProgress(text)` as it goes. Resolves with `{ ok: true, source }` once the head is
 * ready (`source`: what a `.glb` became, from the answer), or `{ ok: false, text }`.
 */
export async function registerHead({ nodes, files, id, token, onProgress }) {
  let chosen;
  try {
    if (!validId(id)) {
      throw new Error(`"${id}" is not a head id: lowercase letters, digits, - and _, at most 64`);
    }
    chosen = chooseFiles(files);
  } catch (error) {
    return { ok: false, text: error.message };
  }
  onProgress("Sending the files");
  let answer;
  try {
    const { path, init } = await registrationRequest(chosen, id, token);
    const response = await nodes.fetch(path, init);
    if (response.status !== 202) {
      return { ok: false, text: `Not registered: ${await refusal(response)}` };
    }
    answer = await response.json().catch(() => ({}));
  } catch (error) {
    return { ok: false, text: `Not registered: ${error.message}` };
  }
  const until = performance.now() + FOLLOW_MS;
  while (performance.now() < until) {
    let info = null;
    try {
      const response = await nodes.fetch(`/v1/heads/${encodeURIComponent(id)}`, token ? { headers: { Authorization: `Bearer ${token}` } } : undefined);
      info = response.ok ? await response.json() : null;
    } catch {
      // A lost answer: ask again.
    }
    if (info?.status === "ready") {
      return { ok: true, source: answer.source ?? null };
    }
    if (info?.status === "failed") {
      return { ok: false, text: `The head did not register: ${info.error ?? "no reason given"}` };
    }
    const percent = Math.round(100 * Number(info?.progress ?? 0));
    onProgress(`Fitting the head: ${percent} %`);
    await new Promise((resolve) => setTimeout(resolve, POLL_MS));
  }
  return { ok: false, text: `The head is still registering after ${FOLLOW_MS / 1000} s; it shows in the list when ready` };
}
