// camera.js: the one orbit camera every view shares, so two algorithms are seen from the
// same angle. It frames a head's face (front +z, up +y), or its mouth from close by for
// people who watch the lips, turns drag, wheel, pinch and keys into orbit and zoom, and
// builds the matrices the renderer needs.

const FIELD_OF_VIEW = (30 * Math.PI) / 180;
const START_YAW = 0.35; // radians, a little to the head's left: depth reads better than head-on
const START_PITCH = 0.08;
const CLOSE_UP_YAW = 0.15; // nearly head-on: the lips and the teeth behind them read best
const CLOSE_UP_PITCH = 0.05;
const CLOSE_UP_HALF_HEIGHT_MM = 32; // a 64 mm tall view: the lips, the chin's top, the nose's base
// Seen from the side, the close-up looks this far behind the lips and above them: the
// middle of the oral cavity, so the lips, the teeth and the tongue's back are in view.
const SIDE_CLOSE_UP_BEHIND_MM = 30;
const SIDE_CLOSE_UP_ABOVE_MM = 4;
const MAX_PITCH = 1.45;
const KEY_STEP = 0.08; // radians per arrow key press
const ZOOM_STEP = 1.15;

export class OrbitCamera {
  constructor() {
    this.target = [0, 0, 0];
    this.sideTarget = this.target; // where a view from the side looks (matrices with a turn)
    this.radius = 1; // half the height framed
    this.depth = 0; // from the target to the front of the face
    this.extent = 1; // from the target to the farthest corner of the mesh's box
    this.closeUp = false;
    this.framings = { face: null, mouth: null };
    this.listeners = [];
    this.reset();
  }

  /**
   * Frames the face of a head (flat xyz positions, front +z, up +y): the front-most vertex
   * is taken as the nose tip, and the view shows about 240 mm around it, turning about a
   * point 80 mm behind it (roughly the centre of a head), inside the mesh's bounds.
   */
  frame(positions, mmPerUnit, mouth) {
    const min = [Infinity, Infinity, Infinity];
    const max = [-Infinity, -Infinity, -Infinity];
    let nose = 0;
    for (let i = 0; i < positions.length; i += 3) {
      for (let k = 0; k < 3; k++) {
        min[k] = Math.min(min[k], positions[i + k]);
        max[k] = Math.max(max[k], positions[i + k]);
      }
      if (positions[i + 2] > positions[nose + 2]) {
        nose = i;
      }
    }
    const mm = 1 / mmPerUnit;
    const clamp = (x, k) => Math.max(min[k], Math.min(max[k], x));
    const extent = (target) => Math.hypot(...[0, 1, 2].map((k) => Math.max(max[k] - target[k], target[k] - min[k])));
    const target = [
      (min[0] + max[0]) / 2,
      clamp(positions[nose + 1] + 20 * mm, 1),
      clamp(positions[nose + 2] - 80 * mm, 2),
    ];
    this.framings.face = {
      target,
      sideTarget: target,
      radius: Math.min(120 * mm, Math.max(max[0] - min[0], max[1] - min[1]) / 2),
      depth: positions[nose + 2] - target[2],
      extent: extent(target),
    };
    // The mouth (head units, from the snapshot): looked at from just in front of the lips.
    this.framings.mouth = mouth
      ? {
          target: [...mouth],
          sideTarget: [mouth[0], mouth[1] + SIDE_CLOSE_UP_ABOVE_MM * mm, mouth[2] - SIDE_CLOSE_UP_BEHIND_MM * mm],
          radius: CLOSE_UP_HALF_HEIGHT_MM * mm,
          depth: 8 * mm,
          extent: extent(mouth),
        }
      : null;
    this.useFraming();
  }

  /** Whether a mouth close-up is possible (the framed head gave its mouth). */
  get hasMouth() {
    return this.framings.mouth !== null;
  }

  /** Looks at the mouth from close by (`on`), or at the whole face. */
  setCloseUp(on) {
    this.closeUp = on;
    this.useFraming();
  }

  useFraming() {
    const framing = (this.closeUp && this.framings.mouth) || this.framings.face;
    if (framing) {
      ({ target: this.target, sideTarget: this.sideTarget, radius: this.radius, depth: this.depth, extent: this.extent } =
        framing);
    }
    this.reset();
  }

  /** The yaw the camera starts at (and reset() goes back to). */
  startYaw() {
    return this.closeUp && this.framings.mouth ? CLOSE_UP_YAW : START_YAW;
  }

  reset() {
    const closeUp = this.closeUp && this.framings.mouth;
    this.yaw = this.startYaw();
    this.pitch = closeUp ? CLOSE_UP_PITCH : START_PITCH;
    this.zoom = 1;
    this.changed();
  }

  orbit(dYaw, dPitch) {
    this.yaw += dYaw;
    this.pitch = Math.max(-MAX_PITCH, Math.min(MAX_PITCH, this.pitch + dPitch));
    this.changed();
  }

  /** factor > 1 moves closer. */
  zoomBy(factor) {
    this.zoom = Math.max(0.3, Math.min(8, this.zoom * factor));
    this.changed();
  }

  zoomIn() {
    this.zoomBy(ZOOM_STEP);
  }

  zoomOut() {
    this.zoomBy(1 / ZOOM_STEP);
  }

  onChange(listener) {
    this.listeners.push(listener);
  }

  changed() {
    for (const listener of this.listeners) {
      listener();
    }
  }

  /**
   * `{ view, projection, eye }` for a viewport of the given aspect (width / height). `turn`
   * (radians about the vertical, 0 from the front) is where the view looks from when the
   * camera is at its start: a side view is the same orbit seen from its side.
   */
  matrices(aspect, turn = 0) {
    const fit = this.radius / Math.tan(FIELD_OF_VIEW / 2) / Math.min(1, aspect);
    const distance = (fit * 1.1 + this.depth) / this.zoom;
    const yaw = turn === 0 ? this.yaw : this.yaw - this.startYaw() + turn;
    const target = turn === 0 ? this.target : this.sideTarget;
    const eye = [
      target[0] + distance * Math.cos(this.pitch) * Math.sin(yaw),
      target[1] + distance * Math.sin(this.pitch),
      target[2] + distance * Math.cos(this.pitch) * Math.cos(yaw),
    ];
    const near = Math.max(distance - this.extent, distance * 0.01);
    return {
      view: lookAt(eye, target, [0, 1, 0]),
      projection: perspective(FIELD_OF_VIEW, aspect, near, distance + this.extent),
      eye,
    };
  }
}

/**
 * Drag (mouse, pen, one finger) orbits; the wheel and a two-finger pinch zoom. `cameraOf()`
 * gives the camera they move, asked at each move (an element may change groups).
 */
export function attachPointerControls(element, cameraOf) {
  const pointers = new Map();
  let pinch = 0;
  const spread = () => {
    const [a, b] = [...pointers.values()];
    return Math.hypot(a.x - b.x, a.y - b.y);
  };
  element.addEventListener("pointerdown", (event) => {
    element.setPointerCapture(event.pointerId);
    pointers.set(event.pointerId, { x: event.clientX, y: event.clientY });
    if (pointers.size === 2) {
      pinch = spread();
    }
  });
  element.addEventListener("pointermove", (event) => {
    const last = pointers.get(event.pointerId);
    if (!last) {
      return;
    }
    const dx = event.clientX - last.x;
    const dy = event.clientY - last.y;
    pointers.set(event.pointerId, { x: event.clientX, y: event.clientY });
    if (pointers.size === 1) {
      cameraOf().orbit(-dx * 0.01, dy * 0.01);
    } else if (pointers.size === 2) {
      const now = spread();
      if (pinch > 0 && now > 0) {
        cameraOf().zoomBy(now / pinch);
      }
      pinch = now;
    }
  });
  const release = (event) => {
    pointers.delete(event.pointerId);
    pinch = 0;
  };
  element.addEventListener("pointerup", release);
  element.addEventListener("pointercancel", release);
  element.addEventListener(
    "wheel",
    (event) => {
      event.preventDefault();
      cameraOf().zoomBy(Math.exp(-event.deltaY * (event.deltaMode === 1 ? 0.05 : 0.0015)));
    },
    { passive: false },
  );
}

/** Arrow keys orbit, + and - zoom, 0 resets; true when the key was the camera's. */
export function handleCameraKey(event, camera) {
  if (event.altKey || event.ctrlKey || event.metaKey) {
    return false;
  }
  switch (event.key) {
    case "ArrowLeft":
      camera.orbit(KEY_STEP, 0);
      break;
    case "ArrowRight":
      camera.orbit(-KEY_STEP, 0);
      break;
    case "ArrowUp":
      camera.orbit(0, KEY_STEP);
      break;
    case "ArrowDown":
      camera.orbit(0, -KEY_STEP);
      break;
    case "+":
    case "=":
      camera.zoomIn();
      break;
    case "-":
    case "_":
      camera.zoomOut();
      break;
    case "0":
    case "Home":
      camera.reset();
      break;
    default:
      return false;
  }
  return true;
}

// Column-major 4x4 matrices, as WebGL takes them.

function perspective(fovY, aspect, near, far) {
  const f = 1 / Math.tan(fovY / 2);
  const nf = 1 / (near - far);
  return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0]);
}

function lookAt(eye, target, up) {
  const z = normalize(sub(eye, target));
  const x = normalize(cross(up, z));
  const y = cross(z, x);
  return new Float32Array([
    x[0], y[0], z[0], 0,
    x[1], y[1], z[1], 0,
    x[2], y[2], z[2], 0,
    -dot(x, eye), -dot(y, eye), -dot(z, eye), 1,
  ]);
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const normalize = (a) => {
  const length = Math.hypot(a[0], a[1], a[2]) || 1;
  return [a[0] / length, a[1] / length, a[2] / length];
};
