// head-view.js: one live head on one canvas, what a <facewire-head> element
// (facewire-head.js; the page's views are such elements) draws: a viewer socket, the rest mesh, its
// parts, eyes, lips and texture fetched once, frames kept raw as they arrive (only their fixed
// header is read) and decoded only when one is drawn, so a slow machine skips frames
// instead of falling behind, and the WebGL2 renderer. It has no controls and no numbers:
// whoever holds it is told what happens through handlers and shows what it likes. While
// a sound plays (sound.js), frames wait for their `t` to be heard.

import { applyFrame, decodeFrame, motionMatrix, parseTextureCoords, readFrameHeader } from "./decode.js";
import { HeadRenderer } from "./render.js";
import { quantile } from "./quantile.js";
import { VIEW_FORMAT, ViewerSocket } from "./stream.js";

/** The Oculus names of the 15 MPEG-4 visemes, in their order (FWF2 `viseme`). */
const VISEME_NAMES = ["sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"];

/** What a frame says: its label, else the viseme it shows (a face derived from a voice). */
export function saidBy(frame) {
  const { label, viseme } = frame;
  if (label) {
    return label;
  }
  return viseme ? VISEME_NAMES[viseme.blend >= 32 ? viseme.select1 : viseme.select2] : null;
}

/** Raw frames kept while waiting to be drawn; older ones are dropped. */
const KEEP_FRAMES = 8;
/** While the sound plays frames wait for their `t` to be heard: up to 3 s of 30 fps. */
const KEEP_FRAMES_FOR_SOUND = 90;
/** Frame intervals kept for frameIntervalS. */
const INTERVALS = 15;

/** The centre of the box around flat xyz positions. */
function boxCentre(positions) {
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) {
    for (let k = 0; k < 3; k++) {
      min[k] = Math.min(min[k], positions[i + k]);
      max[k] = Math.max(max[k], positions[i + k]);
    }
  }
  return min.map((m, k) => (m + max[k]) / 2);
}

const ignore = () => {};

export class HeadView {
  /**
   * `canvas`: where the head is drawn; `nodes`: the Nodes (nodes.js) sockets go to;
   * `loadMesh(url)` and `loadWeights(url, vertexCount)`: promises of a parsed mesh and of
   * a mesh's vertex weights (decode.js: the lips of the head, the tongue of its tongue
   * part), which the caller may share between views; `sound`:
   * the Sound (sound.js) frames wait for while it plays, and `audio`: the codec this view
   * asks for and feeds the sound with, or null. `handlers`, each optional:
   * - `onState(state, detail)`: the socket's state (stream.js);
   * - `onSnapshot(snapshot)`;
   * - `onMesh(url, mesh, mouth)`: a new rest mesh is shown;
   * - `onParts(parts, eyes)`: the snapshot's parts and eyes, then `onPartsLoaded()` once drawn;
   * - `onLips(status)`: `loaded` or `none`;
   * - `onFrameHeader(header, buffer, arrivalUs)`: a frame arrived (not yet decoded);
   * - `onSkipped(count)`: frames received that will not be drawn;
   * - `onAudio({bytes, codec})`: an audio chunk arrived (the socket's pump hands it to the
   *   sound's audio thread);
   * - `onReplay(message)`: where a replay stands (`frame`, `playing`, `speed`, `loop`);
   * - `onShown(frame, said)`: a frame is shown (drawn with the next draw);
   * - `onProblem(text)`: something people should read (an unreadable frame, a mesh that
   *   does not match).
   */
  constructor({ canvas, nodes, loadMesh, loadWeights, sound = null, audio = null, handlers = {} }) {
    this.nodes = nodes;
    this.node = nodes.index;
    this.loadMesh = loadMesh;
    this.loadWeights = loadWeights;
    this.sound = sound;
    this.audio = audio;
    this.on = new Proxy(handlers, { get: (h, name) => h[name] ?? ignore });
    this.renderer = new HeadRenderer(canvas);
    this.socket = new ViewerSocket({
      onSnapshot: (snapshot) => this.snapshotArrived(snapshot),
      onFrame: (buffer, arrivalUs) => this.frameArrived(buffer, arrivalUs),
      onAudio: (notice) => this.audioArrived(notice),
      onReplay: (message) => this.replayMoved(message),
      onState: (state, detail) => this.on.onState(state, detail),
    });
    this.mesh = null;
    this.meshUrl = null;
    /** The frame shown last, on the current mesh. */
    this.shown = null;
    this.snapshot = null;
    this.pending = [];
    this.lastSeq = null;
    this.lastT = null;
    this.intervals = [];
    this.lastArrival = -Infinity;
    this.generation = 0;
    this.needsDraw = true;
    /** The heat-map's ramp top for frames that carry per-vertex values. */
    this.heatScale = 0;
    if (this.audio && this.sound) {
      this.sound.addSource(this.socket);
    }
  }

  get state() {
    return this.socket.state;
  }

  get playing() {
    return this.sound?.playing ?? false;
  }

  /**
   * Connects to `stream` of `head`, or with `replay` to that recording of it, with
   * `algorithm` (a letter or spec; the server's default when empty), `heat` (null,
   * "roughness" or "folds") and `token`, on the nodes' current node, moving to the next
   * one after a lost connection. A replay's sound is its recording's voice, if it has one.
   */
  connect({ head, stream, replay = null, algorithm, heat = null, token = "" }) {
    const query = new URLSearchParams({ format: VIEW_FORMAT });
    if (algorithm) {
      query.set("algo", algorithm);
    }
    if (heat) {
      query.set("heat", heat);
    }
    if (token) {
      query.set("token", token);
    }
    if (this.audio) {
      query.set("audio", this.audio);
    }
    const path = replay
      ? `/v1/heads/${encodeURIComponent(head)}/recordings/${encodeURIComponent(replay)}/view`
      : `/v1/heads/${encodeURIComponent(head)}/streams/${encodeURIComponent(stream)}/view`;
    this.generation += 1;
    this.pending = [];
    this.socket.open((lost) => this.socketUrl(`${path}?${query}`, lost));
  }

  /**
   * The URL of the socket's next attempt: after a lost connection, on the node after the
   * one lost (unless another view or a fetch moved on already), else the current one.
   */
  socketUrl(path, lost) {
    if (lost) {
      this.nodes.advance(this.node);
    }
    this.node = this.nodes.index;
    return this.nodes.wsUrl(path);
  }

  /** Steers a replay (proto/PROTOCOL.md, "Recordings and replay"); false when not sent. */
  control(message) {
    return this.socket.send(message);
  }

  /** Closes the socket and gives the GPU context back. */
  destroy() {
    this.generation += 1;
    this.sound?.removeSource(this.socket);
    this.socket.destroy();
    this.renderer.dispose();
  }

  snapshotArrived(snapshot) {
    this.generation += 1;
    this.pending = [];
    this.lastSeq = null;
    this.snapshot = snapshot;
    this.on.onSnapshot(snapshot);
    if (snapshot.rest_mesh === this.meshUrl) {
      return;
    }
    this.mesh = null;
    this.shown = null;
    this.meshUrl = snapshot.rest_mesh;
    this.loadMesh(snapshot.rest_mesh).then(
      (mesh) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return; // another head was picked meanwhile
        }
        if (mesh.vertexCount !== snapshot.vertices) {
          this.on.onProblem(`The rest mesh has ${mesh.vertexCount} vertices, the snapshot says ${snapshot.vertices}.`);
          return;
        }
        this.mesh = mesh;
        this.positions = new Float32Array(mesh.positions);
        this.renderer.setMesh(mesh);
        this.renderer.setCutCentre(snapshot.mouth ?? boxCentre(mesh.positions));
        this.on.onMesh(snapshot.rest_mesh, mesh, snapshot.mouth);
        this.needsDraw = true;
        this.loadParts(snapshot);
        this.loadLips(snapshot, mesh);
        this.loadTexture(snapshot, mesh);
      },
      (error) => {
        this.meshUrl = null;
        this.on.onProblem(`Cannot load the rest mesh ${snapshot.rest_mesh}: ${error.message}`);
      },
    );
  }

  /**
   * The snapshot's parts (teeth, gums, tongue) and eyes, drawn once their meshes (and the
   * tongue part's `tongue_proper` weights, from servers that send them) arrive.
   */
  loadParts(snapshot) {
    const parts = snapshot.parts ?? [];
    const eyes = snapshot.eyes ?? [];
    this.on.onParts(parts, eyes);
    const tongueOf = (part, mesh) => (part.tongue_proper ? this.loadWeights(part.tongue_proper, mesh.vertexCount) : null);
    const loaded = Promise.all([...parts, ...eyes].map((p) => this.loadMesh(p.mesh))).then((meshes) =>
      Promise.all(parts.map((p, i) => tongueOf(p, meshes[i]))).then((tongues) => [meshes, tongues]),
    );
    loaded.then(
      ([meshes, tongues]) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return;
        }
        this.renderer.setParts(
          parts.map((p, i) => ({ name: p.name, role: p.role, mesh: meshes[i], tongue: tongues[i] })),
        );
        this.renderer.setEyes(eyes.map((eye, i) => ({ eye, mesh: meshes[parts.length + i] })));
        if (this.shown) {
          this.shapeParts(this.shown);
        }
        this.on.onPartsLoaded();
        this.needsDraw = true;
      },
      (error) => this.on.onProblem(`Cannot load the head's parts: ${error.message}`),
    );
  }

  /**
   * The head's texture, when the snapshot names one: its coordinates (`uv.bin`) and its
   * image, fetched from the nodes as the meshes are and drawn once both arrive.
   */
  loadTexture(snapshot, mesh) {
    if (!snapshot.texture) {
      return;
    }
    const get = (url) =>
      this.nodes.fetch(url).then((response) => {
        if (!response.ok) {
          throw new Error(`${url}: HTTP ${response.status}`);
        }
        return response;
      });
    const uv = get(snapshot.texture.uv)
      .then((response) => response.arrayBuffer())
      .then((buffer) => parseTextureCoords(buffer, mesh.triangleCount));
    const image = get(snapshot.texture.image)
      .then((response) => response.blob())
      .then((blob) => createImageBitmap(blob));
    Promise.all([uv, image]).then(
      ([coords, bitmap]) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return;
        }
        this.renderer.setTexture(coords, bitmap);
        this.needsDraw = true;
      },
      (error) => this.on.onProblem(`Cannot load the head's texture: ${error.message}`),
    );
  }

  /**
   * Where the head's lips are (the snapshot's `lip_tint`, absent from older servers), for
   * drawing them in their own colour.
   */
  loadLips(snapshot, mesh) {
    if (!snapshot.lip_tint) {
      this.on.onLips("none");
      return;
    }
    this.loadWeights(snapshot.lip_tint, mesh.vertexCount).then(
      (weights) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return;
        }
        this.renderer.setLipTint(weights);
        this.on.onLips("loaded");
        this.needsDraw = true;
      },
      (error) => {
        this.on.onLips("none");
        this.on.onProblem(`Cannot load where the lips are (${snapshot.lip_tint}): ${error.message}`);
      },
    );
  }

  /** How the head is looked at (render.js setLook). */
  setLook(look) {
    this.renderer.setLook(look);
    this.needsDraw = true;
  }

  /** How the lips are drawn (render.js setLips). */
  setLips(lips) {
    this.renderer.setLips(lips);
    this.needsDraw = true;
  }

  /** The heat-map's ramp top, shown at once. */
  setHeatScale(scale) {
    this.heatScale = scale;
    this.renderer.setHeatScale(scale);
    this.needsDraw = true;
  }

  frameArrived(buffer, arrivalUs) {
    let header;
    try {
      header = readFrameHeader(buffer);
    } catch (error) {
      this.on.onProblem(`Unreadable frame: ${error.message}`);
      return;
    }
    if (this.lastSeq !== null && header.seq > this.lastSeq + 1) {
      this.on.onSkipped(header.seq - this.lastSeq - 1);
    }
    if (this.lastSeq !== null && header.seq <= this.lastSeq) {
      this.pending = []; // a new producer started the stream over, or a replay went back
    }
    this.lastSeq = header.seq;
    this.lastArrival = performance.now();
    this.on.onFrameHeader(header, buffer, arrivalUs);
    if (this.lastT !== null && header.producerTimeS > this.lastT) {
      this.intervals.push(header.producerTimeS - this.lastT);
      if (this.intervals.length > INTERVALS) {
        this.intervals.shift();
      }
    }
    this.lastT = header.producerTimeS;
    const entry = { seq: header.seq, t: header.producerTimeS, buffer, decoded: null };
    if (this.playing) {
      // Frames wait about the playout delay for their sound: decode them now, so that
      // when one is due it is drawn at once, not after an inflate whose time varies.
      entry.decoded = this.decode(buffer);
    }
    this.pending.push(entry);
    if (this.pending.length > (this.playing ? KEEP_FRAMES_FOR_SOUND : KEEP_FRAMES)) {
      this.pending.shift();
      this.on.onSkipped(1);
    }
  }

  /** The stream's time between frames (median of the last few), seconds; 0 before two frames. */
  frameIntervalS() {
    return quantile(this.intervals, 0.5) ?? 0;
  }

  /**
   * Where a replay stands now (each such message also starts a new run of its voice, which
   * the socket's pump tells the sound, in order with the chunks).
   */
  replayMoved(message) {
    this.on.onReplay(message);
  }

  /** An audio chunk arrived: counted, or its problem told. */
  audioArrived(notice) {
    if (notice.problem) {
      this.on.onProblem(`Unreadable audio: ${notice.problem}`);
      return;
    }
    this.on.onAudio(notice);
  }

  /** The newest sequence number received, for keeping two views on the same frame. */
  newestSeq() {
    return this.lastSeq ?? -1;
  }

  /**
   * Decodes the newest waiting frame no newer than `target` (older ones are dropped and
   * counted as skipped), or takes it as decoded on arrival while the sound plays: `{seq}`,
   * a sequence number both views have, or `{t}`, the stream time being heard. A promise
   * of the frame, or null when there is nothing to draw.
   */
  prepare(target) {
    if (!this.mesh || this.pending.length === 0) {
      return null;
    }
    const due = target.t === undefined ? (p) => p.seq <= target.seq : (p) => p.t <= target.t;
    let i = this.pending.findLastIndex(due);
    if (i < 0) {
      if (this.pending.length < (target.t === undefined ? KEEP_FRAMES : KEEP_FRAMES_FOR_SOUND)) {
        return null; // not due yet, or the other view has not caught up
      }
      i = 0;
    }
    const { buffer, decoded } = this.pending[i];
    if (i > 0) {
      this.on.onSkipped(i);
    }
    this.pending.splice(0, i + 1);
    return decoded ?? this.decode(buffer);
  }

  /** A promise of `buffer` decoded, or of null when it is unreadable or the view moved on. */
  decode(buffer) {
    const generation = this.generation;
    return decodeFrame(buffer).then(
      (frame) => (generation === this.generation ? frame : null),
      (error) => {
        this.on.onProblem(`Unreadable frame: ${error.message}`);
        return null;
      },
    );
  }

  /** Shows a decoded frame: positions, the tongue's shape, the eyes, the heat-map. */
  show(frame) {
    if (frame.vertexCount !== this.mesh.vertexCount) {
      this.on.onProblem(`A frame for ${frame.vertexCount} vertices arrived for a mesh of ${this.mesh.vertexCount}.`);
      return;
    }
    applyFrame(this.mesh.positions, frame, this.positions);
    this.renderer.setPositions(this.positions);
    this.renderer.setMotion(motionMatrix(frame.head), motionMatrix(frame.jaw));
    this.shown = frame;
    this.shapeParts(frame);
    this.renderer.setHeat(frame.face, this.heatScale);
    this.needsDraw = true;
    this.on.onShown(frame, saidBy(frame));
  }

  /**
   * The tongue's shape and the eyes' turns of `frame`, on the parts and eyes loaded now:
   * again when they load after the frame was shown (a paused replay, a still stream).
   */
  shapeParts(frame) {
    const problem = this.renderer.setTongue(frame.tongue, frame.tongue?.step);
    if (problem) {
      this.on.onProblem(problem);
    }
    const eyeProblem = this.renderer.setEyeMotions(frame.eyes);
    if (eyeProblem) {
      this.on.onProblem(eyeProblem);
    }
  }

  /** Draws when something changed (or `force`), with `camera` (camera.js). */
  draw(camera, force) {
    if (this.needsDraw || force || this.renderer.fitCanvas()) {
      this.renderer.draw(camera);
      this.needsDraw = false;
    }
  }
}
