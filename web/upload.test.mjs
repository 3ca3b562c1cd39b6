// upload.test.mjs: checks how the page builds a head's registration (upload.js): ids from
// file names, which files make a head and which are refused with what words, and the
// requests, against the protocol's `POST /v1/heads` (JSON with the OBJ text and the image
// in base64, or a `.glb`'s bytes with `?id=`). Run `node web/upload.test.mjs`; the exit
// status is the verdict. Not served: the page never loads this file.

import {
  base64,
  chooseFiles,
  idFromFileName,
  packGlb,
  readGlb,
  registrationRequest,
  sourceSummary,
  validId,
  writeGlb,
} from "./upload.js";

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
equal(chooseFiles([glb]).kind, "gltf", "a .glb alone");
const chosen = chooseFiles([obj, file("face.mtl", "map_Kd face.png\n"), png]);
equal([chosen.kind, chosen.obj.name, chosen.image.name], ["obj", "face.obj", "face.png"], "an .obj, its .mtl and image");
equal(chooseFiles([obj]).image, null, "an .obj alone");
refused([], "pick a head", "nothing picked");
refused([png], "pick a head", "an image alone");
refused([obj, glb], "one head at a time: avatar.glb, face.obj", "two heads");
refused([obj, file("face.bin", [1])], "a .bin goes with a .gltf", "a .bin with an .obj");
const separate = chooseFiles([file("a.gltf", "{}"), file("a.bin", [1]), png]);
equal([separate.kind, separate.file.name, separate.others.map((f) => f.name)], ["gltf", "a.gltf", ["a.bin", "face.png"]], "a .gltf with its files");
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
// A .glb with everything inside goes as it is.
const whole = writeGlb({ asset: { version: "2.0" }, buffers: [{ byteLength: 4 }] }, new Uint8Array([1, 2, 3, 4]));
const avatar = await registrationRequest(chooseFiles([file("avatar.glb", whole)]), "av", "");
equal(avatar.path, "/v1/heads?id=av", "glb: the path");
equal(avatar.init.headers, { "Content-Type": "model/gltf-binary" }, "glb: headers, no token");
equal([...new Uint8Array(avatar.init.body)], [...new Uint8Array(whole)], "glb: the file's bytes");

// A glTF written as separate files (its buffer and image beside it, one image a data: URI)
// packed into one .glb: one buffer, every view moved by where its buffer went (4-byte
// aligned), every image given a view of its bytes and its MIME type, nothing named by URI.
const gltf = {
  asset: { version: "2.0" },
  buffers: [{ uri: "mesh%20data.bin", byteLength: 6 }, { uri: "data:application/octet-stream;base64,CQoL", byteLength: 3 }],
  bufferViews: [
    { buffer: 0, byteOffset: 2, byteLength: 4 },
    { buffer: 1, byteLength: 3 },
  ],
  images: [{ uri: "textures/face.png" }, { uri: "data:image/jpeg;base64,/9j/" }],
};
const bin = [1, 2, 3, 4, 5, 6];
const packedRequest = await registrationRequest(
  chooseFiles([file("avatar.gltf", JSON.stringify(gltf)), file("mesh data.bin", bin), png]),
  "sep",
  "",
);
equal(packedRequest.path, "/v1/heads?id=sep", "gltf: sent as a .glb");
const packed = readGlb(packedRequest.init.body);
const view = (i) => {
  const v = packed.json.bufferViews[i];
  return [...packed.bin.subarray(v.byteOffset, v.byteOffset + v.byteLength)];
};
equal(packed.json.buffers, [{ byteLength: 6 + 2 + 3 + 1 + 9 + 3 + 3 }], "gltf: one buffer (each piece 4-byte aligned)");
equal(view(0), [3, 4, 5, 6], "gltf: the first view, where it was");
equal(view(1), [9, 10, 11], "gltf: the second buffer's view, moved after the first (aligned)");
equal(packed.json.bufferViews[1].byteOffset, 8, "gltf: 4-byte aligned");
equal(view(2), [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0xff], "gltf: the image file inside");
equal(view(3), [0xff, 0xd8, 0xff], "gltf: the data: image inside");
equal(packed.json.images, [{ bufferView: 2, mimeType: "image/png" }, { bufferView: 3, mimeType: "image/jpeg" }], "gltf: images");
equal(JSON.stringify(packed.json).includes("uri"), false, "gltf: no URI left");
try {
  packGlb(gltf, null, new Map());
  failures.push("gltf: packed without its .bin");
} catch (error) {
  equal(error.message, 'the glTF\'s buffer 0 is the file "mesh data.bin": pick it too', "gltf: a file missing");
}
// A .glb naming its image by URI: the image picked beside it is put inside.
const glbWithUri = writeGlb(
  { asset: { version: "2.0" }, buffers: [{ byteLength: 4 }], images: [{ uri: "face.png" }] },
  new Uint8Array([7, 7, 7, 7]),
);
const repacked = readGlb((await registrationRequest(chooseFiles([file("av.glb", glbWithUri), png]), "av", "")).init.body);
equal(repacked.json.images, [{ bufferView: 0, mimeType: "image/png" }], "glb: its URI image put inside");
equal([...repacked.bin.subarray(0, 4)], [7, 7, 7, 7], "glb: its own chunk kept");

// What a .glb became, in words.
equal(sourceSummary(null), "", "source: none");
equal(sourceSummary({ format: "glb", skin: "Head", parts: [], left_out: [] }), "", "source: nothing to say");
equal(
  sourceSummary({
    texture: "the skin's base colour image, image/png",
    arkit_targets: [{ blendshape: "jawOpen", from: ["jawOpen"] }, { blendshape: "browInnerUp", from: ["browInnerUp_L", "browInnerUp_R"] }],
    targets_left_out: [{ name: "smile", why: "not named like an ARKit blendshape" }],
  }),
  "Texture: the skin's base colour image, image/png. ARKit: 2 blendshapes from its own morph targets. " +
    "Morph targets not used: smile (not named like an ARKit blendshape).",
  "source: texture, ARKit targets, one left out",
);
equal(
  sourceSummary({ targets_left_out: ["a", "b", "c", "d", "e", "f", "g"].map((name) => ({ name, why: "w" })) }),
  "Morph targets not used: a, b, c, d, e and 2 more (w, ...).",
  "source: many left out",
);

if (failures.length > 0) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log("upload: ok");
