// panel.js: one view of the page: its algorithm picker, heat-map switch and look, the
// live head (a <facewire-head> element, facewire-head.js, in the page's group: one camera,
// one sound, drawn in step with the other view) and the numbers under it, read from the
// element's events (connection state, syllable, fps, latency per hop, bytes per frame, lip
// roughness and folds). A live stream that stops sending shows as stalled. Given a list
// of nodes (nodes.js), each reconnect after a lost connection goes to the next node, and
// the status line names it. The view that carries the page's sound (sound.js) asks for
// audio (the element's `audio`); while the sound plays, every view draws the frame whose
// `t` is being heard and shows how far each drawn frame was from its sound.

import { CLOSE } from "./codes.js";
import { DEFAULT_HEAT_MAX, FOLDS_RAMP_TOP_DEG } from "./facewire-head.js";
import { LOOKS } from "./render.js";
import { quantile } from "./quantile.js";

export { DEFAULT_HEAT_MAX };
/** A live stream with no frame for this long is shown as stalled. */
const STALL_MS = 2000;
/** A largest dihedral increase below this (degrees), with no triangle turned over 60
 * degrees, is a bend rather than a fold: the "Lip folds" line says "none". */
const FOLD_BEND_DEG = 30;

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
   * `index`: 0 or 1; `container`: where the view goes; `algorithms`: the /v1/algorithms
   * list; `chart`: the page's LiveChart; `group`: the page's HeadGroup (head-group.js: the
   * shared camera and sound); `nodes`: the page's Nodes (nodes.js), shared by both views
   * and the fetches; `audio`: the codec this view asks the voice in, or null (the other
   * view, or no sound); `look` and `lips`: how the head is drawn; `onSettings()`: the
   * user changed this view's algorithm, heat-map or look; `onReplay(message)`: where a
   * replay stands; `onRecording(recording)`: the snapshot's `replay` (the recording
   * replayed), or null; `onKey(event)`: a key the head did not take (the page's `m`).
   */
  constructor({
    index,
    container,
    algorithms,
    chart,
    group,
    nodes,
    audio,
    look,
    lips,
    onSettings,
    onReplay,
    onRecording,
    onKey,
  }) {
    this.index = index;
    this.sound = group.sound;
    this.audio = audio;
    this.nodes = nodes;
    this.chart = chart;
    this.group = group;
    this.onRecording = onRecording ?? (() => {});
    // Imported into this document and upgraded, so the element is a FacewireHead before it
    // is connected (its group and nodes are set first).
    const fragment = document.importNode(document.getElementById("view-template").content, true);
    customElements.upgrade(fragment);
    this.parts = {};
    for (const element of fragment.querySelectorAll("[data-part]")) {
      element.id = `${element.dataset.part}-${index}`;
      this.parts[element.dataset.part] = element;
    }
    for (const label of fragment.querySelectorAll("label[data-for]")) {
      label.htmlFor = `${label.dataset.for}-${index}`;
    }
    const { view: root, title, algo, heat, heatkind, heatmax, head, look: lookPicker, cut } = this.parts;
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
    this.root = root;
    this.head = head;
    this.listen(head, { onReplay, onKey });
    head.nodes = nodes;
    group.add(head);
    if (audio) {
      head.setAttribute("audio", audio);
    }
    this.setLook(look ?? { mode: "front", cutDeg: 0 });
    this.setLips(lips);
    this.resetStats();
    container.append(fragment); // the element connects once its attributes are set (connect())
    chart.setSeries(index, getComputedStyle(root).getPropertyValue("--accent").trim());
  }

  /** What the element tells: the numbers, the messages, the replay. */
  listen(head, { onReplay, onKey }) {
    const on = (name, handle) => head.addEventListener(name, (event) => handle(event.detail));
    on("state", ({ state, ...detail }) => this.stateChanged(state, detail));
    on("snapshot", ({ snapshot }) => this.snapshotArrived(snapshot));
    on("parts", ({ parts, eyes, loaded }) => (loaded ? this.partsLoaded() : this.partsListed(parts, eyes)));
    on("lips", ({ status }) => {
      this.parts.view.dataset.lips = status;
    });
    on("arrival", ({ header, bytes, arrivalUs }) => this.frameArrived(header, bytes, arrivalUs));
    on("skipped", ({ count }) => {
      this.stats.skipped += count;
    });
    on("audio", ({ bytes }) => {
      this.stats.audioBytes += bytes;
    });
    on("frame", ({ frame, said }) => this.shown(frame, said));
    on("replay", ({ message }) => onReplay?.(message));
    on("error", ({ message, kind }) => {
      if (kind === "problem") {
        this.showMessage(message);
      }
    });
    head.addEventListener("keydown", (event) => {
      if (!event.defaultPrevented) {
        onKey?.(event);
      }
    });
  }

  /** The element's live view (head-view.js), null while it connects again. */
  get view() {
    return this.head.headView;
  }

  /**
   * Connects with `settings`: { head, stream, replay, algorithm, heat (null, "roughness"
   * or "folds"), heatMax, token, knownStreams }.
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
    this.head.setAttribute("view", this.look.mode);
    this.head.setAttribute("cut", String(degrees));
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
    this.head.setAttribute("heatmax", String(this.settings.heatMax));
  }

  /** The element's attributes as the settings say: any that changed reconnects it, once. */
  reconnect() {
    const { head, stream, replay, algorithm, heat, token } = this.settings;
    const set = (name, value) => (value ? this.head.setAttribute(name, value) : this.head.removeAttribute(name));
    set("head", head);
    set("stream", stream);
    set("replay", replay);
    set("algo", algorithm);
    set("heat", heat);
    set("token", token);
  }

  /** `text` for the status line, with the node in use when the page has a list of them. */
  statusText(text) {
    const node = this.nodes.label(this.view?.node ?? this.nodes.index);
    return node ? `${text} · node ${node}` : text;
  }

  destroy() {
    this.group.remove(this.head);
    this.chart.removeSeries(this.index);
    this.root.remove();
  }

  get state() {
    return this.head.state;
  }

  snapshotArrived(snapshot) {
    this.onRecording(snapshot.replay ?? null);
    this.chart.breakLine(this.index, performance.now());
    this.parts.algorithm.textContent = snapshot.algorithm;
    if (this.audio) {
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
  setLips({ mode, strength }) {
    this.head.setAttribute("lips", mode);
    this.head.setAttribute("lipstrength", String(strength));
  }

  /** A frame arrived (its header read): the numbers and the chart. */
  frameArrived(header, bytes, arrivalUs) {
    const stats = this.stats;
    stats.received += 1;
    stats.bytes += bytes;
    stats.serverUs += header.serverSendUs - header.serverReceiveUs;
    stats.deliveryUs += arrivalUs - header.serverSendUs;
    const arrival = this.view.lastArrival;
    this.markStall(arrival);
    this.lip = header.lip;
    this.chart.push(this.index, arrival, header.lip.mean);
  }

  /** A frame is shown: its syllable, its lip folds, and how late it is for eye and ear. */
  shown(frame, said) {
    this.parts.view.dataset.seq = String(frame.seq);
    this.parts.syllable.textContent = said ?? "–";
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

  /** Steers this view's replay (the element's control). */
  control(message) {
    return this.head.control(message);
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
      // A close code: the server refused; none: the page cannot show what it got (a frame
      // layout it does not read, no WebGL2).
      const missing = detail.code === CLOSE.unknown_head;
      const what = missing ? "Not found" : detail.code === undefined ? "Cannot show the head" : "Refused";
      this.showMessage(`${what}: ${detail.message}.${missing ? " Pick a registered head above." : ""}`);
    } else if (state === "reconnecting") {
      const node = this.nodes.label(this.view?.node ?? this.nodes.index);
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
    const idle = now - (this.view?.lastArrival ?? now);
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
      `delay ${summary.delayMs.toFixed(0)} ms (needs ${summary.targetMs.toFixed(0)}, of which the face ${summary.faceMs.toFixed(0)})`,
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
    const scale = this.head.group?.drawScale.scale ?? 1;
    if (scale < 1) {
      parts.push(`drawn at ${Math.round(scale * 100)} % a side to keep up`);
    }
    return parts.join(" · ");
  }
}
