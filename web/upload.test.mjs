// upload.test.mjs: checks how the page builds a head's registration (upload.js): ids from
// file names, which files make a head and which are refused with what words, and the
// requests, against the protocol's `POST /v1/heads` (JSON with the OBJ text and the image
// in base64, or a `.glb`'s bytes with `?id=`). Run `node web/upload.test.mjs`; the exit
// status is the verdict. Not served: the page never loads this file.

import { base64, chooseFiles, idFromFileName, registrationRequest, validId } from "./upload.js";

const failures = [];

function equal(actual, expected, what) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${what}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

function refused(files, words, what) {
  try {
    chooseFiles(files);
    failures.push(`${what}: taken`);
  } catch (error) {
    if (!error.message.includes(words)) {
      failures.push(`${what}: "${error.message}" does not say "${words}"`);
    }
  }
}

/** A picked file, as the browser's File has it (name, text(), arrayBuffer()). */
function file(name, bytes) {
  const data = typeof bytes === "string" ? new TextEncoder().encode(bytes) : new Uint8Array(bytes);
  return {
    name,
    text: async () => new TextDecoder().decode(data),
    arrayBuffer: async () => data.buffer.slice(data.byteOffset, data.byteOffset + data.byteLength),
  };
}

equal(idFromFileName("My Head (2).glb"), "my-head-2", "id from a file name");
equal(idFromFileName("scan_v3.OBJ"), "scan_v3", "id keeps _ and lowercases");
equal(idFromFileName("Ölkopf.obj"), "lkopf", "id drops what ids cannot hold");
equal(idFromFileName("???.glb"), "head", "id when nothing is left");
equal(idFromFileName(`${"a".repeat(80)}.obj`).length, 64, "id at most 64");
equal(
  ["scan", "call-17", "x_y", "", "Scan", "a b", "a".repeat(65)].map(validId),
  [true, true, true, false, false, false, false],
  "ids as the server takes them (src/server/ids.rs)",
);

const obj = file("face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
const png = file("face.png", [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0xff]);
const glb = file("avatar.glb", [0x67, 0x6c, 0x54, 0x46, 2, 0, 0, 0]);
equal(chooseFiles([glb]).kind, "glb", "a .glb alone");
const chosen = chooseFiles([obj, file("face.mtl", "map_Kd face.png\n"), png]);
equal([chosen.kind, chosen.obj.name, chosen.image.name], ["obj", "face.obj", "face.png"], "an .obj, its .mtl and image");
equal(chooseFiles([obj]).image, null, "an .obj alone");
refused([], "pick a head", "nothing picked");
refused([png], "pick a head", "an image alone");
refused([obj, glb], "one head at a time: avatar.glb, face.obj", "two heads");
refused([glb, png], "leave out face.png", "an image with a .glb");
refused([obj, png, file("b.jpg", [1])], "one texture image at most", "two images");
refused([obj, file("notes.txt", "x")], "notes.txt: not a", "another kind of file");

// base64 as the server decodes it, also past one piece of 32 KiB.
equal(base64(new Uint8Array([0, 1, 2, 250, 255])), "AAEC+v8=", "base64 by hand");
const big = new Uint8Array(100_000).map((_, i) => (i * 7) % 256);
equal(base64(big), Buffer.from(big).toString("base64"), "base64 of 100,000 bytes");

const withImage = await registrationRequest(chosen, "my-face", "s3cret");
equal(withImage.path, "/v1/heads", "OBJ: the path");
equal(withImage.init.method, "POST", "OBJ: the method");
equal(withImage.init.headers, { Authorization: "Bearer s3cret", "Content-Type": "application/json" }, "OBJ: headers");
equal(
  JSON.parse(withImage.init.body),
  { id: "my-face", obj: "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", texture: "iVBORw0KGgr/" },
  "OBJ: the body, the image in base64",
);
const avatar = await registrationRequest(chooseFiles([glb]), "av", "");
equal(avatar.path, "/v1/heads?id=av", "glb: the path");
equal(avatar.init.headers, { "Content-Type": "model/gltf-binary" }, "glb: headers, no token");
equal([...new Uint8Array(avatar.init.body)], [0x67, 0x6c, 0x54, 0x46, 2, 0, 0, 0], "glb: the file's bytes");

if (failures.length > 0) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log("upload: ok");
