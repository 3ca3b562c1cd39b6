// upload.js: a head of the user's own, registered from the page. The user picks the files
// (a glTF avatar `.glb`, or an `.obj` with, optionally, its texture image), names the head,
// and the server fits it (the automatic fit: no landmarks needed); the page follows the
// registration's progress, then shows the head and its fit report. The request is what
// proto/PROTOCOL.md describes for `POST /v1/heads` (JSON with the OBJ text and the image
// in base64, or the `.glb`'s bytes with `?id=`); the files go to the facewire server and
// nowhere else. The request is built by pure functions (node tests them: upload.test.mjs).

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
 * What to send for `files` (objects with `name`; a `.glb`, or an `.obj` and at most one
 * PNG or JPEG image; a `.mtl` is accepted and not needed): `{ kind: "glb", file }` or
 * `{ kind: "obj", obj, image }` (the files, not read yet). Throws an Error that says what
 * is missing or too much, naming the files.
 */
export function chooseFiles(files) {
  const by = (exts) => files.filter((f) => exts.includes(extension(f.name)));
  const glbs = by(["glb"]);
  const objs = by(["obj"]);
  const images = by(Object.keys(IMAGE_TYPES));
  const others = files.filter((f) => !["glb", "obj", "mtl", ...Object.keys(IMAGE_TYPES)].includes(extension(f.name)));
  if (others.length > 0) {
    throw new Error(`${others.map((f) => f.name).join(", ")}: not a .glb, .obj, .mtl, PNG or JPEG file`);
  }
  if (glbs.length + objs.length === 0) {
    throw new Error("pick a head: a .glb avatar, or an .obj (with its texture image if it has one)");
  }
  if (glbs.length + objs.length > 1) {
    throw new Error(`one head at a time: ${[...glbs, ...objs].map((f) => f.name).join(", ")}`);
  }
  if (glbs.length === 1) {
    if (images.length > 0) {
      throw new Error(`a .glb brings its own texture: leave out ${images.map((f) => f.name).join(", ")}`);
    }
    return { kind: "glb", file: glbs[0] };
  }
  if (images.length > 1) {
    throw new Error(`one texture image at most: ${images.map((f) => f.name).join(", ")}`);
  }
  return { kind: "obj", obj: objs[0], image: images[0] ?? null };
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
  if (chosen.kind === "glb") {
    return {
      path: `/v1/heads?id=${encodeURIComponent(id)}`,
      init: {
        method: "POST",
        headers: { ...headers, "Content-Type": "model/gltf-binary" },
        body: await chosen.file.arrayBuffer(),
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
