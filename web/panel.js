// panel.js: one view of the page: its algorithm picker and heat-map switch, a viewer
// socket, the 3D head and the numbers under it (connection state, syllable, fps, latency
// per hop, bytes per frame, lip roughness and folds). A live stream that stops sending
// shows as stalled. Frames are kept raw as they arrive (only their fixed header is read,
// for the numbers and the chart); the page decodes just the one it draws, so a slow
// machine skips frames instead of falling behind. Given a list of nodes (nodes.js), each
// reconnect after a lost connection goes to the next node, and the status line names it.
// The view that carries the page's sound (sound.js) asks for audio and hands its chunks
// over; while the sound plays, every view draws the frame whose `t` is being heard, keeping
// frames until then, and shows how far each drawn frame was from its sound.

import { applyFrame, decodeAudio, decodeFrame, motionMatrix, readFrameHeader } from "./decode.js";
import { HeadRenderer, LOOKS } from "./render.js";
import { CLOSE } from "./codes.js";
import { quantile } from "./sound.js";
import { VIEW_FORMAT, ViewerSocket } from "./stream.js";

/** The Oculus names of the 15 MPEG-4 visemes, in their order (FWF2 `viseme`). */
const VISEME_NAMES = ["sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"];

/** What a frame's viseme shows, for a frame without a label (a face derived from a voice). */
function visemeName(viseme) {
  return viseme ? VISEME_NAMES[viseme.blend >= 32 ? viseme.select1 : viseme.select2] : null;
}

/** Raw frames kept while waiting to be drawn; older ones are dropped. */
const KEEP_FRAMES = 8;
/** While the sound plays frames wait for their `t` to be heard: up to 3 s of 30 fps. */
const KEEP_FRAMES_FOR_SOUND = 90;
/** Frame intervals kept for frameIntervalS. */
const INTERVALS = 15;
/** Face roughness (mean 1 - n·n around a vertex) at the top of the heat-map ramp, unless
 * the view picks another. */
export const DEFAULT_HEAT_MAX = 0.1;
/** A live stream with no frame for this long is shown as stalled. */
const STALL_MS = 2000;
/** A largest dihedral increase below this (degrees), with no triangle turned over 60
 * degrees, is a bend rather than a fold: the "Lip folds" line says "none". */
const FOLD_BEND_DEG = 30;
/** Coloured by folds, a vertex whose triangles turned this far (degrees) tops the ramp. */
const FOLDS_RAMP_TOP_DEG = 90;

const STATE_TEXT = {
  connecting: "Connecting",
  waiting: "Waiting for frames",
  live: "Live",
  ended: "Ended",
  reconnecting: "Reconnecting",
  error: "Error",
};

/**
 * The "Lip folds" line for a frame's `folds` ({turnedOver60, turnedOver90,
 * maxDihedralIncreaseDeg}, or null when the server did not measure them).
 */
function foldsText(folds) {
  if (!folds) {
    return "not sent";
  }
  const { turnedOver60, turnedOver90, maxDihedralIncreaseDeg } = folds;
  const sharpest = `sharpest +${maxDihedralIncreaseDeg.toFixed(1)}°`;
  if (turnedOver60 === 0) {
    return maxDihedralIncreaseDeg < FOLD_BEND_DEG ? "none" : `no triangle over 60°, ${sharpest}`;
  }
  const triangles = turnedOver60 === 1 ? "triangle" : "triangles";
  return `${turnedOver60.toLocaleString("en")} ${triangles} over 60° (${turnedOver90.toLocaleString("en")} over 90°), ${sharpest}`;
}

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

export class Panel {
  /**
   * `index`: 0 or 1; `algorithms`: the /v1/algorithms list; `loadMesh(url)`: a promise of
   * a parsed mesh; `loadLipTint(url, vertexCount)`: a promise of a head's lip weights
   * (decode.js parseLipTint); `lips`: how the lips are drawn (render.js setLips);
   * `onMesh(url, mesh)`: a mesh is shown; `onSettings()`: the user changed
   * this view's algorithm or heat-map; `nodes`: the page's Nodes (nodes.js), shared by
   * both views and the fetches; `sound`: the page's Sound (sound.js), whose clock the view
   * draws by, and `audio`: the codec this view asks for and feeds the sound with, or null
   * (the other view, or no sound).
   */
  constructor({ index, container, algorithms, chart, loadMesh, loadLipTint, onMesh, onSettings, nodes, sound, audio, look, lips }) {
    this.index = index;
    this.sound = sound;
    this.audio = audio;
    this.nodes = nodes;
    this.node = nodes.index;
    this.chart = chart;
    this.loadMesh = loadMesh;
    this.loadLipTint = loadLipTint;
    this.onMesh = onMesh;
    const fragment = document.getElementById("view-template").content.cloneNode(true);
    this.parts = {};
    for (const element of fragment.querySelectorAll("[data-part]")) {
      element.id = `${element.dataset.part}-${index}`;
      this.parts[element.dataset.part] = element;
    }
    for (const label of fragment.querySelectorAll("label[data-for]")) {
      label.htmlFor = `${label.dataset.for}-${index}`;
    }
    const { view: root, title, algo, heat, heatkind, heatmax, canvas, look: lookPicker, cut } = this.parts;
    root.classList.add(`view-${index}`);
    root.setAttribute("aria-labelledby", title.id);
    title.textContent = `View ${index + 1}`;
    for (const a of algorithms) {
      algo.add(new Option(`${a.letter}: ${a.description}`, a.spec));
    }
    algo.addEventListener("change", () => {
      this.settings.algorithm = algo.value;
      this.reconnect();
      onSettings();
    });
    heat.addEventListener("change", () => {
      this.settings.heat = heat.checked ? heatkind.value : null;
      this.showHeatControls();
      this.reconnect();
      onSettings();
    });
    heatkind.addEventListener("change", () => {
      this.settings.heat = heatkind.value;
      this.showHeatControls();
      this.reconnect();
      onSettings();
    });
    heatmax.addEventListener("change", () => {
      this.settings.heatMax = Number(heatmax.value);
      this.showHeatControls();
      this.needsDraw = true;
      onSettings();
    });
    lookPicker.addEventListener("change", () => {
      this.setLook({ ...this.look, mode: lookPicker.value });
      onSettings();
    });
    cut.addEventListener("input", () => {
      this.setLook({ ...this.look, cutDeg: Number(cut.value) });
      onSettings();
    });
    container.append(fragment);
    this.root = root;
    chart.setSeries(index, getComputedStyle(root).getPropertyValue("--accent").trim());

    this.renderer = new HeadRenderer(canvas);
    this.setLook(look ?? { mode: "front", cutDeg: 0 });
    this.setLips(lips);
    this.socket = new ViewerSocket({
      onSnapshot: (snapshot) => this.snapshotArrived(snapshot),
      onFrame: (buffer, arrivalUs) => this.frameArrived(buffer, arrivalUs),
      onAudio: (buffer) => this.audioArrived(buffer),
      onState: (state, detail) => this.stateChanged(state, detail),
    });
    this.mesh = null;
    this.meshUrl = null;
    this.pending = [];
    this.lastSeq = null;
    this.lastT = null;
    this.intervals = [];
    this.lastArrival = -Infinity;
    this.generation = 0;
    this.needsDraw = true;
    this.resetStats();
  }

  /**
   * Connects with `settings`: { head, stream, algorithm, heat (null, "roughness" or
   * "folds"), heatMax, token, knownStreams }.
   */
  connect(settings) {
    this.settings = { ...settings };
    const { algo, heat, heatkind, heatmax } = this.parts;
    if (![...algo.options].some((o) => o.value === settings.algorithm)) {
      algo.add(new Option(`${settings.algorithm} (as given)`, settings.algorithm));
    }
    algo.value = settings.algorithm;
    heat.checked = Boolean(settings.heat);
    heatkind.value = settings.heat ?? "roughness";
    const scale = String(settings.heatMax);
    if (![...heatmax.options].some((o) => o.value === scale)) {
      heatmax.add(new Option(`${scale} (as given)`, scale));
    }
    heatmax.value = scale;
    this.showHeatControls();
    this.reconnect();
  }

  /**
   * How this view looks at the head: `mode` one of render.js LOOKS (front, side, cutaway,
   * see-through), `cutDeg` the cut's turn from the midsagittal plane (-90 to 90 degrees).
   * Only the drawing changes; the socket stays.
   */
  setLook({ mode, cutDeg }) {
    const { look, cut, cutfield, cutvalue } = this.parts;
    const degrees = Math.max(-90, Math.min(90, Math.round(Number(cutDeg) / 5) * 5 || 0));
    this.look = { mode: LOOKS.includes(mode) ? mode : "front", cutDeg: degrees };
    look.value = this.look.mode;
    cut.value = String(degrees);
    cutvalue.textContent = `${degrees}°`;
    cut.setAttribute("aria-valuetext", `${degrees} degrees from the midsagittal plane`);
    cutfield.hidden = this.look.mode !== "cutaway";
    this.renderer.setLook(this.look);
    this.needsDraw = true;
  }

  /** The known streams changed (the page re-reads the list): only the messages use them. */
  setKnownStreams(knownStreams) {
    this.settings.knownStreams = knownStreams;
  }

  showHeatControls() {
    const { heat, kindfield, heatfield, legend, legendmax } = this.parts;
    const folds = this.settings.heat === "folds";
    kindfield.hidden = legend.hidden = !heat.checked;
    heatfield.hidden = !heat.checked || folds;
    legendmax.textContent = folds ? `${FOLDS_RAMP_TOP_DEG}° turned or more` : `${this.settings.heatMax} or more`;
    this.renderer.setHeatScale(this.heatScale());
  }

  /** The value at the top of the heat-map's ramp: degrees for folds, else the chosen roughness. */
  heatScale() {
    return this.settings.heat === "folds" ? FOLDS_RAMP_TOP_DEG : this.settings.heatMax;
  }

  reconnect() {
    const { head, stream, algorithm, heat, token } = this.settings;
    const query = new URLSearchParams({ algo: algorithm, format: VIEW_FORMAT });
    if (heat) {
      query.set("heat", heat);
    }
    if (token) {
      query.set("token", token);
    }
    if (this.audio) {
      query.set("audio", this.audio);
    }
    const path = `/v1/heads/${encodeURIComponent(head)}/streams/${encodeURIComponent(stream)}/view`;
    this.generation += 1;
    this.pending = [];
    this.socket.open((lost) => this.socketUrl(`${path}?${query}`, lost));
  }

  /**
   * The URL of the socket's next attempt: after a lost connection, on the node after the
   * one lost (unless the other view or a fetch moved on already), else the current one.
   */
  socketUrl(path, lost) {
    if (lost) {
      this.nodes.advance(this.node);
    }
    this.node = this.nodes.index;
    return this.nodes.wsUrl(path);
  }

  /** `text` for the status line, with the node in use when the page has a list of them. */
  statusText(text) {
    const node = this.nodes.label(this.node);
    return node ? `${text} · node ${node}` : text;
  }

  destroy() {
    this.generation += 1;
    this.socket.close();
    this.renderer.dispose();
    this.chart.removeSeries(this.index);
    this.root.remove();
  }

  get state() {
    return this.socket.state;
  }

  snapshotArrived(snapshot) {
    this.generation += 1;
    this.pending = [];
    this.chart.breakLine(this.index, performance.now());
    this.lastSeq = null;
    this.parts.algorithm.textContent = snapshot.algorithm;
    if (this.audio) {
      this.sound.reset();
      this.soundProblem =
        snapshot.audio === this.audio ? null : `this server sends no audio (asked for ${this.audio})`;
    }
    if (snapshot.rest_mesh === this.meshUrl) {
      return;
    }
    this.mesh = null;
    this.meshUrl = snapshot.rest_mesh;
    this.loadMesh(snapshot.rest_mesh).then(
      (mesh) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return; // another head was picked meanwhile
        }
        if (mesh.vertexCount !== snapshot.vertices) {
          this.showMessage(`The rest mesh has ${mesh.vertexCount} vertices, the snapshot says ${snapshot.vertices}.`);
          return;
        }
        this.mesh = mesh;
        this.positions = new Float32Array(mesh.positions);
        this.renderer.setMesh(mesh);
        this.renderer.setCutCentre(snapshot.mouth ?? boxCentre(mesh.positions));
        this.onMesh(snapshot.rest_mesh, mesh, snapshot.mouth);
        this.needsDraw = true;
        this.loadParts(snapshot);
        this.loadLips(snapshot, mesh);
      },
      (error) => {
        this.meshUrl = null;
        this.showMessage(`Cannot load the rest mesh ${snapshot.rest_mesh}: ${error.message}`);
      },
    );
  }

  /**
   * The snapshot's parts (teeth, gums, tongue) and eyes, drawn once their meshes arrive;
   * the "Inner mouth" and "Eyes" lines name them (`data-loaded` is set once they are
   * drawn).
   */
  loadParts(snapshot) {
    const parts = snapshot.parts ?? [];
    const eyes = snapshot.eyes ?? [];
    const { inner, eyes: eyeLine } = this.parts;
    inner.textContent = parts.length > 0 ? parts.map((p) => `${p.name} (${p.role})`).join(", ") : "none";
    eyeLine.textContent = eyes.length > 0 ? eyes.map((e) => `${e.name} (${e.side})`).join(", ") : "none";
    delete inner.dataset.loaded;
    delete eyeLine.dataset.loaded;
    Promise.all([...parts, ...eyes].map((p) => this.loadMesh(p.mesh))).then(
      (meshes) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return;
        }
        this.renderer.setParts(parts.map((p, i) => ({ name: p.name, role: p.role, mesh: meshes[i] })));
        this.renderer.setEyes(eyes.map((eye, i) => ({ eye, mesh: meshes[parts.length + i] })));
        inner.dataset.loaded = String(parts.length);
        eyeLine.dataset.loaded = String(eyes.length);
        this.needsDraw = true;
      },
      (error) => this.showMessage(`Cannot load the head's parts: ${error.message}`),
    );
  }

  /**
   * Where the head's lips are (the snapshot's `lip_tint`, absent from older servers), for
   * drawing them in their own colour; the view's `data-lips` says `loaded` or `none`.
   */
  loadLips(snapshot, mesh) {
    const { view } = this.parts;
    delete view.dataset.lips;
    if (!snapshot.lip_tint) {
      view.dataset.lips = "none";
      return;
    }
    this.loadLipTint(snapshot.lip_tint, mesh.vertexCount).then(
      (weights) => {
        if (snapshot.rest_mesh !== this.meshUrl) {
          return;
        }
        this.renderer.setLipTint(weights);
        view.dataset.lips = "loaded";
        this.needsDraw = true;
      },
      (error) => {
        view.dataset.lips = "none";
        this.showMessage(`Cannot load where the lips are (${snapshot.lip_tint}): ${error.message}`);
      },
    );
  }

  /** How the lips are drawn (render.js setLips): the page's choice, for every view. */
  setLips(lips) {
    this.renderer.setLips(lips);
    this.needsDraw = true;
  }

  frameArrived(buffer, arrivalUs) {
    let header;
    try {
      header = readFrameHeader(buffer);
    } catch (error) {
      this.showMessage(`Unreadable frame: ${error.message}`);
      return;
    }
    const stats = this.stats;
    stats.received += 1;
    stats.bytes += buffer.byteLength;
    stats.serverUs += header.serverSendUs - header.serverReceiveUs;
    stats.deliveryUs += arrivalUs - header.serverSendUs;
    if (this.lastSeq !== null && header.seq > this.lastSeq + 1) {
      stats.skipped += header.seq - this.lastSeq - 1;
    }
    if (this.lastSeq !== null && header.seq <= this.lastSeq) {
      this.pending = []; // a new producer started the stream over
      if (this.audio) {
        this.sound.reset(); // and its timeline
      }
    }
    this.lastSeq = header.seq;
    this.lastArrival = performance.now();
    this.markStall(this.lastArrival);
    this.lip = header.lip;
    this.chart.push(this.index, this.lastArrival, header.lip.mean);
    if (this.lastT !== null && header.producerTimeS > this.lastT) {
      this.intervals.push(header.producerTimeS - this.lastT);
      if (this.intervals.length > INTERVALS) {
        this.intervals.shift();
      }
    }
    this.lastT = header.producerTimeS;
    const entry = { seq: header.seq, t: header.producerTimeS, buffer, decoded: null };
    if (this.sound.playing) {
      // Frames wait about the playout delay for their sound: decode them now, so that
      // when one is due it is drawn at once, not after an inflate whose time varies.
      entry.decoded = this.decode(buffer);
    }
    this.pending.push(entry);
    if (this.pending.length > (this.sound.playing ? KEEP_FRAMES_FOR_SOUND : KEEP_FRAMES)) {
      this.pending.shift();
      stats.skipped += 1;
    }
  }

  /** The stream's time between frames (median of the last few), seconds; 0 before two frames. */
  frameIntervalS() {
    return quantile(this.intervals, 0.5) ?? 0;
  }

  /** An audio chunk for the page's sound. */
  audioArrived(buffer) {
    let chunk;
    try {
      chunk = decodeAudio(buffer);
    } catch (error) {
      this.showMessage(`Unreadable audio: ${error.message}`);
      return;
    }
    this.stats.audioBytes += buffer.byteLength;
    this.sound.push(chunk);
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
    this.stats.skipped += i;
    this.pending.splice(0, i + 1);
    return decoded ?? this.decode(buffer);
  }

  /** A promise of `buffer` decoded, or of null when it is unreadable or the view moved on. */
  decode(buffer) {
    const generation = this.generation;
    return decodeFrame(buffer).then(
      (frame) => (generation === this.generation ? frame : null),
      (error) => {
        this.showMessage(`Unreadable frame: ${error.message}`);
        return null;
      },
    );
  }

  /** Shows a decoded frame: positions, the tongue's shape, the eyes, heat-map, syllable, lip folds. */
  show(frame) {
    if (frame.vertexCount !== this.mesh.vertexCount) {
      this.showMessage(`A frame for ${frame.vertexCount} vertices arrived for a mesh of ${this.mesh.vertexCount}.`);
      return;
    }
    applyFrame(this.mesh.positions, frame, this.positions);
    this.renderer.setPositions(this.positions);
    const problem = this.renderer.setTongue(frame.tongue, frame.tongue?.step);
    if (problem) {
      this.showMessage(problem);
    }
    this.renderer.setMotion(motionMatrix(frame.head), motionMatrix(frame.jaw));
    const eyeProblem = this.renderer.setEyeMotions(frame.eyes);
    if (eyeProblem) {
      this.showMessage(eyeProblem);
    }
    this.renderer.setHeat(frame.face, this.heatScale());
    const said = frame.label ?? visemeName(frame.viseme);
    this.parts.syllable.textContent = said ?? "–";
    this.parts.label.textContent = said ?? "";
    this.folds = frame.folds;
    this.stats.drawn += 1;
    this.stats.eyeUs += Date.now() * 1000 - frame.serverReceiveUs;
    const heardMs = this.sound.heardAtMsForTime(frame.producerTimeS);
    if (heardMs !== null) {
      const offsetMs = performance.now() - heardMs;
      this.stats.offsets.push(offsetMs);
      this.sound.logSync(this.index, frame, offsetMs);
    }
    this.needsDraw = true;
  }

  draw(camera, force) {
    if (this.needsDraw || force || this.renderer.fitCanvas()) {
      this.renderer.draw(camera);
      this.needsDraw = false;
    }
  }

  stateChanged(state, detail) {
    const { status } = this.parts;
    status.dataset.state = state;
    let text = STATE_TEXT[state];
    if (state === "reconnecting") {
      text += ` in ${(detail.retryMs / 1000).toFixed(1)} s`;
    }
    status.textContent = this.statusText(text);
    if (state === "error") {
      const missing = detail.code === CLOSE.unknown_head;
      this.showMessage(`${missing ? "Not found" : "Refused"}: ${detail.message}.${missing ? " Pick a registered head above." : ""}`);
    } else if (state === "reconnecting") {
      const node = this.nodes.label(this.node);
      this.showMessage(`Connection lost (${detail.message}); trying again${node ? ` on node ${node}` : ""}.`);
    } else if (state === "ended") {
      this.showMessage(`The stream ended: ${detail.message}. Waiting for it to start again.`);
    } else if (state === "waiting" && !this.settings.knownStreams.includes(this.settings.stream)) {
      const { head, stream, knownStreams } = this.settings;
      const known = knownStreams.join(", ") || "none";
      this.showMessage(
        `No stream "${stream}" on head "${head}" yet (streams with frames: ${known}). Waiting for a producer.`,
      );
    } else {
      this.showMessage(null);
    }
  }

  /** Shows "stalled" instead of "Live" while a live stream sends nothing, and back. */
  markStall(now) {
    const { status } = this.parts;
    if (this.state !== "live") {
      return;
    }
    const idle = now - this.lastArrival;
    if (idle >= STALL_MS) {
      status.dataset.state = "stalled";
      status.textContent = this.statusText(`Stalled: no frame for ${Math.floor(idle / 1000)} s`);
    } else if (status.dataset.state === "stalled") {
      status.dataset.state = "live";
      status.textContent = this.statusText(STATE_TEXT.live);
    }
  }

  showMessage(text) {
    const { message } = this.parts;
    message.hidden = !text;
    message.textContent = text ?? "";
  }

  resetStats() {
    this.stats = {
      since: performance.now(),
      received: 0,
      drawn: 0,
      skipped: 0,
      bytes: 0,
      audioBytes: 0,
      serverUs: 0,
      deliveryUs: 0,
      eyeUs: 0,
      offsets: [],
    };
  }

  /** Writes the last second's numbers under the view and starts a new second. */
  updateStats(now) {
    this.markStall(now);
    const s = this.stats;
    const seconds = (now - s.since) / 1000;
    const { fps, latency, bytes, lip, folds } = this.parts;
    this.parts.sound.textContent = this.soundText(s, seconds, now);
    if (s.received === 0) {
      fps.textContent = "none in the last second";
      latency.textContent = bytes.textContent = "–";
    } else {
      const n = s.received;
      fps.textContent = `${(n / seconds).toFixed(1)} in, ${(s.drawn / seconds).toFixed(1)} drawn, ${s.skipped} skipped`;
      const ms = (us) => (us / n / 1000).toFixed(1);
      const eye = s.drawn > 0 ? `, to eye ${(s.eyeUs / s.drawn / 1000).toFixed(0)} ms` : "";
      latency.textContent = `server ${ms(s.serverUs)} ms, delivery ${ms(s.deliveryUs)} ms${eye}`;
      bytes.textContent = `${Math.round(s.bytes / n).toLocaleString("en")} B`;
    }
    if (this.lip) {
      const { mean, min, max } = this.lip;
      lip.textContent = `mean ${mean.toFixed(4)} (min ${min.toFixed(4)}, max ${max.toFixed(4)})`;
    }
    if (this.folds !== undefined) {
      folds.textContent = foldsText(this.folds);
    }
    this.resetStats();
  }

  /** The "Sound" line: codec, playout delay, latency to the ear, and how far the face was from the voice. */
  soundText(s, seconds, now) {
    if (!this.audio) {
      return this.sound.playing ? "the other view's (one sound for both)" : "off";
    }
    if (this.soundProblem) {
      return this.soundProblem;
    }
    const summary = this.sound.summary(now);
    if (!summary) {
      const kbps = (s.audioBytes / 1024 / seconds).toFixed(1);
      return this.sound.context ? `waiting for audio (${kbps} kB/s)` : `off: press Sound on (${kbps} kB/s arriving)`;
    }
    const parts = [
      `${summary.codec}, ${(s.audioBytes / 1024 / seconds).toFixed(1)} kB/s`,
      `delay ${summary.delayMs.toFixed(0)} ms (jitter needs ${summary.targetMs.toFixed(0)})`,
      `output ${summary.outputMs.toFixed(0)} ms`,
    ];
    if (summary.earMs !== null) {
      parts.push(`to ear ${summary.earMs.toFixed(0)} ms`);
    }
    if (s.offsets.length > 0) {
      const median = quantile(s.offsets, 0.5);
      parts.push(`face ${median >= 0 ? "+" : ""}${median.toFixed(0)} ms from voice`);
    }
    if (summary.late > 0) {
      parts.push(`${summary.late} late`);
    }
    return parts.join(" · ");
  }
}
