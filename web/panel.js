// panel.js: one view of the page: its algorithm picker, heat-map switch and look, the
// live head (head-view.js: the socket, the meshes, the frames, the drawing, shared with
// the <facewire-head> element) and the numbers under it (connection state, syllable, fps,
// latency per hop, bytes per frame, lip roughness and folds). A live stream that stops
// sending shows as stalled. Given a list of nodes (nodes.js), each reconnect after a lost
// connection goes to the next node, and the status line names it. The view that carries
// the page's sound (sound.js) asks for audio and hands its chunks over; while the sound
// plays, every view draws the frame whose `t` is being heard and shows how far each drawn
// frame was from its sound.

import { CLOSE } from "./codes.js";
import { HeadView } from "./head-view.js";
import { LOOKS } from "./render.js";
import { quantile } from "./sound.js";
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
/** The lengths the scale bar may show, mm. */
const SCALE_LENGTHS_MM = [1, 2, 5, 10, 20, 50, 100];

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

export class Panel {
  /**
   * `index`: 0 or 1; `algorithms`: the /v1/algorithms list; `loadMesh(url)`: a promise of
   * a parsed mesh; `loadWeights(url, vertexCount)`: a promise of a mesh's vertex weights
   * (decode.js parseVertexWeights: the lips, the tongue part's tongue); `lips`: how the lips are drawn (render.js setLips);
   * `onMesh(url, mesh)`: a mesh is shown; `onSettings()`: the user changed
   * this view's algorithm or heat-map; `onReplay(message)`: where a replay stands;
   * `onRecording(recording)`: the snapshot's `replay` (the recording replayed), or null; `nodes`: the page's Nodes (nodes.js), shared by
   * both views and the fetches; `sound`: the page's Sound (sound.js), whose clock the view
   * draws by, and `audio`: the codec this view asks for and feeds the sound with, or null
   * (the other view, or no sound).
   */
  constructor({
    index,
    container,
    algorithms,
    chart,
    loadMesh,
    loadWeights,
    onMesh,
    onSettings,
    onReplay,
    onRecording,
    nodes,
    sound,
    audio,
    look,
    lips,
  }) {
    this.index = index;
    this.sound = sound;
    this.audio = audio;
    this.nodes = nodes;
    this.chart = chart;
    this.onRecording = onRecording ?? (() => {});
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

    this.view = new HeadView({
      canvas,
      nodes,
      loadMesh,
      loadWeights,
      sound,
      audio,
      handlers: {
        onState: (state, detail) => this.stateChanged(state, detail),
        onSnapshot: (snapshot) => this.snapshotArrived(snapshot),
        onMesh,
        onParts: (parts, eyes) => this.partsListed(parts, eyes),
        onPartsLoaded: () => this.partsLoaded(),
        onLips: (status) => {
          this.parts.view.dataset.lips = status;
        },
        onFrameHeader: (header, buffer, arrivalUs) => this.frameArrived(header, buffer, arrivalUs),
        onSkipped: (count) => {
          this.stats.skipped += count;
        },
        onAudio: (buffer) => {
          this.stats.audioBytes += buffer.byteLength;
        },
        onShown: (frame, said) => this.shown(frame, said),
        onReplay,
        onProblem: (text) => this.showMessage(text),
      },
    });
    this.setLook(look ?? { mode: "front", cutDeg: 0 });
    this.setLips(lips);
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
    this.view?.setLook(this.look);
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
    this.view.setHeatScale(this.heatScale());
  }

  /** The value at the top of the heat-map's ramp: degrees for folds, else the chosen roughness. */
  heatScale() {
    return this.settings.heat === "folds" ? FOLDS_RAMP_TOP_DEG : this.settings.heatMax;
  }

  reconnect() {
    this.view.connect(this.settings);
  }

  /** `text` for the status line, with the node in use when the page has a list of them. */
  statusText(text) {
    const node = this.nodes.label(this.view.node);
    return node ? `${text} · node ${node}` : text;
  }

  destroy() {
    this.view.destroy();
    this.chart.removeSeries(this.index);
    this.root.remove();
  }

  get state() {
    return this.view.state;
  }

  /** When the newest frame arrived (performance.now()), -Infinity before any. */
  get lastArrival() {
    return this.view.lastArrival;
  }

  snapshotArrived(snapshot) {
    this.onRecording(snapshot.replay ?? null);
    this.chart.breakLine(this.index, performance.now());
    this.parts.algorithm.textContent = snapshot.algorithm;
    if (this.audio) {
      this.sound.restart(1);
      if (snapshot.audio === this.audio) {
        this.soundProblem = null;
      } else {
        this.soundProblem = snapshot.replay
          ? "this recording has no voice"
          : `this server sends no audio (asked for ${this.audio})`;
      }
    }
  }

  /**
   * The "Inner mouth" and "Eyes" lines name the snapshot's parts and eyes (`data-loaded`
   * is set once they are drawn).
   */
  partsListed(parts, eyes) {
    const { inner, eyes: eyeLine } = this.parts;
    inner.textContent = parts.length > 0 ? parts.map((p) => `${p.name} (${p.role})`).join(", ") : "none";
    eyeLine.textContent = eyes.length > 0 ? eyes.map((e) => `${e.name} (${e.side})`).join(", ") : "none";
    delete inner.dataset.loaded;
    delete eyeLine.dataset.loaded;
    this.listed = { parts: parts.length, eyes: eyes.length };
  }

  partsLoaded() {
    this.parts.inner.dataset.loaded = String(this.listed.parts);
    this.parts.eyes.dataset.loaded = String(this.listed.eyes);
  }

  /** How the lips are drawn (render.js setLips): the page's choice, for every view. */
  setLips(lips) {
    this.view.setLips(lips);
  }

  /** A frame arrived (its header read): the numbers and the chart. */
  frameArrived(header, buffer, arrivalUs) {
    const stats = this.stats;
    stats.received += 1;
    stats.bytes += buffer.byteLength;
    stats.serverUs += header.serverSendUs - header.serverReceiveUs;
    stats.deliveryUs += arrivalUs - header.serverSendUs;
    this.markStall(this.view.lastArrival);
    this.lip = header.lip;
    this.chart.push(this.index, this.view.lastArrival, header.lip.mean);
  }

  /** The stream's time between frames (median of the last few), seconds; 0 before two frames. */
  frameIntervalS() {
    return this.view.frameIntervalS();
  }

  /** The newest sequence number received, for keeping two views on the same frame. */
  newestSeq() {
    return this.view.newestSeq();
  }

  /** A promise of the frame to draw for `target`, or null (head-view.js prepare). */
  prepare(target) {
    return this.view.prepare(target);
  }

  /** Shows a decoded frame (head-view.js show); the numbers follow through `shown`. */
  show(frame) {
    this.view.show(frame);
  }

  /** A frame is shown: its syllable, its lip folds, and how late it is for eye and ear. */
  shown(frame, said) {
    this.parts.view.dataset.seq = String(frame.seq);
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
  }

  draw(camera, force) {
    this.view.draw(camera, force);
    this.showScale(this.view.renderer.cssPixelsPerMm);
  }

  /**
   * The scale bar of the side and cut-away looks: the shortest of SCALE_LENGTHS_MM that
   * is at least 40 CSS pixels long at the cut plane; hidden in the other looks.
   */
  showScale(pixelsPerMm) {
    const { scale, scalebar, scalelabel } = this.parts;
    const mm = pixelsPerMm ? SCALE_LENGTHS_MM.find((l) => l * pixelsPerMm >= 40) : undefined;
    scale.hidden = mm === undefined;
    if (mm === undefined) {
      return;
    }
    const width = `${(mm * pixelsPerMm).toFixed(1)}px`;
    if (scalebar.style.width !== width) {
      scalebar.style.width = width;
      scalebar.dataset.mm = String(mm);
      scalelabel.textContent = `${mm} mm`;
    }
  }

  /** Steers this view's replay (head-view.js control). */
  control(message) {
    return this.view.control(message);
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
      const node = this.nodes.label(this.view.node);
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
    const idle = now - this.view.lastArrival;
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
