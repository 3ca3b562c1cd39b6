// look.test.mjs: checks the maths of a view's look (render.js and camera.js): which way
// the side and cut-away views look from, the cut plane carried into view space by the
// head's motion, and where a side view of the mouth close-up centres. Hand-computed
// cases. Run `node web/look.test.mjs`; the exit status is the verdict. Not served: the
// page never loads this file.

import { OrbitCamera } from "./camera.js";
import { HeadRenderer } from "./render.js";

const failures = [];

function near(actual, expected, path, tolerance = 1e-6) {
  const a = [actual].flat();
  const e = [expected].flat();
  if (a.length !== e.length || a.some((x, i) => !(Math.abs(x - e[i]) <= tolerance))) {
    failures.push(`${path}: ${JSON.stringify(a)} != ${JSON.stringify(e)}`);
  }
}

const IDENTITY = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);

/** A renderer without a canvas: only the look's maths is used. */
function renderer(mode, cutDeg, model = IDENTITY) {
  const r = Object.create(HeadRenderer.prototype);
  r.model = model;
  r.cutCentre = [0.1, 0.2, 0.3];
  r.setLook({ mode, cutDeg });
  return r;
}

// The front and see-through looks: from the front, no cut.
for (const mode of ["front", "see-through"]) {
  const r = renderer(mode, 0);
  near(r.cameraTurn(), 0, `${mode}: camera turn`);
  near([...r.clipPlane(IDENTITY)], [0, 0, 0, 0], `${mode}: no cut`);
}

// The side: from the head's left (+x), a quarter turn, whatever the cut's angle.
near(renderer("side", 40).cameraTurn(), Math.PI / 2, "side: camera turn");
near([...renderer("side", 0).clipPlane(IDENTITY)], [0, 0, 0, 0], "side: no cut");

// The midsagittal cut: normal +x through the centre; looked at along it.
{
  const r = renderer("cutaway", 0);
  near(r.cameraTurn(), Math.PI / 2, "cut 0: camera turn");
  near([...r.clipPlane(IDENTITY)], [1, 0, 0, -0.1], "cut 0: plane");
}

// Turned 90 degrees: the coronal plane, normal +z, looked at from the front.
{
  const r = renderer("cutaway", 90);
  near(r.cameraTurn(), 0, "cut 90: camera turn");
  near([...r.clipPlane(IDENTITY)], [0, 0, 1, -0.3], "cut 90: plane", 1e-6);
}

// Turned 45 degrees: normal (1, 0, 1)/sqrt 2, looked at from 45 degrees.
{
  const r = renderer("cutaway", 45);
  near(r.cameraTurn(), Math.PI / 4, "cut 45: camera turn");
  const h = Math.SQRT1_2;
  near([...r.clipPlane(IDENTITY)], [h, 0, h, -(0.1 + 0.3) * h], "cut 45: plane", 1e-6);
}

// The cut moves with the head: moved 1 along z, the coronal plane is 1 further.
{
  const moved = new Float32Array(IDENTITY);
  moved[14] = 1;
  near([...renderer("cutaway", 90, moved).clipPlane(IDENTITY)], [0, 0, 1, -1.3], "moved head: plane", 1e-6);
}

// And turns with it: the head turned 90 degrees about +y takes +x to -z and the centre
// (0.1, 0.2, 0.3) to (0.3, 0.2, -0.1): the plane -z = 0.1.
{
  const turned = new Float32Array([0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1]);
  near([...renderer("cutaway", 0, turned).clipPlane(IDENTITY)], [0, 0, -1, -0.1], "turned head: plane", 1e-6);
}

// A view matrix carries the plane into view space: moved 2 along -z (the camera 2 in front).
{
  const view = new Float32Array(IDENTITY);
  view[14] = -2;
  near([...renderer("cutaway", 90).clipPlane(view)], [0, 0, 1, 1.7], "view: plane", 1e-6);
}

// Bad looks fall back: an unknown mode is the front, a cut that is not a number is 0.
{
  const r = renderer("upside-down", Number.NaN);
  near(r.cameraTurn(), 0, "unknown look: camera turn");
  near(r.look.cutDeg, 0, "NaN cut");
  if (r.look.mode !== "front") {
    failures.push(`unknown look: mode ${r.look.mode}`);
  }
}

// The camera: a side view of the close-up looks at a point 30 mm behind the lips and 4 mm
// above them, from the head's left at the start.
{
  const camera = new OrbitCamera();
  const mmPerUnit = 10; // mm per head unit: 30 mm is 3 units
  const positions = new Float32Array([-8, -10, -10, 8, 10, 1, 0, 0, 2]);
  camera.frame(positions, mmPerUnit, [0, -3, 1]);
  camera.setCloseUp(true);
  near(camera.sideTarget, [0, -3 + 0.4, 1 - 3], "close-up: side target");
  const { eye } = camera.matrices(1, Math.PI / 2);
  near(eye[2], camera.sideTarget[2], "side eye: level with the target in z", 1e-5);
  if (!(eye[0] > camera.sideTarget[0])) {
    failures.push(`side eye: not on the head's left (x ${eye[0]})`);
  }
  const front = camera.matrices(1, 0).eye;
  if (!(front[2] > camera.target[2])) {
    failures.push(`front eye: not in front (z ${front[2]})`);
  }
}

if (failures.length > 0) {
  console.error(`${failures.length} failure(s):\n${failures.join("\n")}`);
  process.exit(1);
}
console.log("look: every case holds");
