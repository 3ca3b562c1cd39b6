// facewire-head.js: the live head as a component any page can embed, with two lines:
//
//   <script type="module" src="http://HOST:8480/facewire-head.js"></script>
//   <facewire-head head="ict" stream="main" view="front"></facewire-head>
//
// A custom element with its own canvas, socket and overlays (what is said, the connection's
// state, a scale bar, a Sound on button), built on the live view (head-view.js: the
// decoding, the meshes, the drawing) and drawn by a group (head-group.js): its own, with
// its own camera (drag, pinch, wheel and keys), or one its page puts several elements in,
// which share a camera and a sound and draw in step. The facewire page is made of these
// elements. Attributes, each read again when it changes:
// - `server`: the facewire server's base URL, or several nodes of a cluster
//   comma-separated (the element fails over between them as the page does); by default
//   the server this module was loaded from (a page may instead set the `nodes` property);
// - `head` (required) and `stream` (default `main`), or `replay`: a recording of the head,
//   replayed by the server (steered with control());
// - `view`: `front` (default), `side`, `cutaway` or `see-through`, and `cut`, the
//   cut-away's turn in degrees;
// - `algo`: a letter or spec (default: the server's); `heat`: `roughness` or `folds` (a
//   heat-map instead of skin), `heatmax`: the roughness ramp's top (default 0.1);
// - `lips`: `tint` (default), `contrast`, `region` or `off`, `lipstrength`: 0 to 1;
// - `mouth`: present for the mouth close-up (on the element's own camera);
// - `audio`: `opus` or `pcm`: the voice, played in sync once the Sound on button is
//   pressed (browsers start sound only after a click);
// - `token`: a viewer token.
// Events: `frame` (detail: `seq`, `t`, `said`, the label or viseme shown, and `frame`, the
// decoded frame), `end` (detail: `message`: the stream ended; the element waits for it to
// start again) and `error` (detail: `message`, `code` and `kind`: `refused`, a refusal
// that retrying cannot fix, which stops the element until an attribute changes, or
// `problem`, something that went wrong while it goes on: an unreadable frame, a lost
// mesh). For pages that show more (the facewire page): `state`, `snapshot`, `arrival` (a
// frame's header, before it is decoded), `skipped`, `audio`, `replay`, `parts`, `lips`
// and `mesh`, described in docs/WEB.md. The `state` property and attribute say
// `connecting`, `waiting`, `live`, `ended`, `reconnecting` or `error`.

import { attachPointerControls, handleCameraKey, OrbitCamera } from "./camera.js";
import { parseVertexWeights, parseMesh } from "./decode.js";
import { HeadGroup } from "./head-group.js";
import { HeadView } from "./head-view.js";
import { Nodes, parseNodes } from "./nodes.js";
import { Sound } from "./sound.js";

const STYLE = `
:host { display: block; position: relative; aspect-ratio: 4 / 3; background: #20242a; overflow: hidden; }
:host([hidden]) { display: none; }
canvas { display: block; width: 100%; height: 100%; touch-action: none; cursor: grab; }
canvas:active { cursor: grabbing; }
canvas:focus-visible { outline: 3px solid #ffbf47; outline-offset: -3px; }
.said { position: absolute; left: 0.6em; top: 0.3em; font: 600 1.6em system-ui, sans-serif; color: #fff;
  text-shadow: 0 1px 3px #000; pointer-events: none; }
.status { position: absolute; left: 0.6em; bottom: 0.4em; font: 0.85em system-ui, sans-serif; color: #ddd;
  text-shadow: 0 1px 2px #000; pointer-events: none; }
.scale { position: absolute; right: 0.6em; bottom: 0.6em; display: flex; flex-direction: column; gap: 0.15em;
  padding: 0.2em 0.5em; border-radius: 3px; font: 0.8em system-ui, sans-serif; color: #f1f3f5;
  background: rgb(20 22 26 / 75%); pointer-events: none; }
.scale .bar { display: block; box-sizing: border-box; height: 0.3em; border: 2px solid #f1f3f5; border-top: none; }
.sound-on { position: absolute; right: 0.5em; top: 0.5em; min-width: 24px; min-height: 24px; font: 0.9em system-ui, sans-serif; }
[hidden] { display: none !important; }
`;

const STATUS_TEXT = {
  connecting: "Connecting",
  waiting: "Waiting for frames",
  live: "",
  ended: "The stream ended; waiting for it to start again",
  reconnecting: "Reconnecting",
  error: "Error",
};

/** The lengths the scale bar may show, mm: the shortest at least 40 px long is shown. */
const SCALE_LENGTHS_MM = [1, 2, 5, 10, 20, 50, 100];
const SCALE_MIN_PX = 40;
/** The heat-map's ramp top for roughness, unless `heatmax` says another. */
export const DEFAULT_HEAT_MAX = 0.1;
/** Coloured by folds, a vertex whose triangles turned this far (degrees) tops the ramp. */
export const FOLDS_RAMP_TOP_DEG = 90;
const HEAT_KINDS = ["roughness", "folds"];
const AUDIO_CODECS = ["opus", "pcm"];

/** Attributes that change only the drawing; every other one reconnects. */
const DRAWING_ATTRIBUTES = new Set(["view", "cut", "lips", "lipstrength", "heatmax", "mouth"]);

/** Meshes and vertex weights by absolute URL, shared by every element on the page. */
const cache = new Map();

function cached(key, load, parse) {
  if (!cache.has(key)) {
    const promise = load().then((response) => {
      if (!response.ok) {
        throw new Error(`HTTP ${response.status}`);
      }
      return response.arrayBuffer().then(parse);
    });
    promise.catch(() => cache.delete(key));
    cache.set(key, promise);
  }
  return cache.get(key);
}

export class FacewireHead extends HTMLElement {
  static observedAttributes = [
    "server",
    "head",
    "stream",
    "replay",
    "view",
    "cut",
    "algo",
    "heat",
    "heatmax",
    "lips",
    "lipstrength",
    "mouth",
    "audio",
    "token",
  ];

  constructor() {
    super();
    const root = this.attachShadow({ mode: "open" });
    root.innerHTML = `<style>${STYLE}</style>
      <span class="said" part="said" aria-live="off"></span><span class="status" part="status" role="status"></span>
      <div class="scale" part="scale" hidden><span class="bar"></span><span class="scale-label"></span></div>
      <button type="button" class="sound-on" part="sound-on" hidden>Sound on</button>`;
    this.canvas = null;
    this.saidLine = root.querySelector(".said");
    this.statusLine = root.querySelector(".status");
    this.scale = root.querySelector(".scale");
    this.scaleBar = root.querySelector(".scale .bar");
    this.scaleLabel = root.querySelector(".scale-label");
    this.soundOn = root.querySelector(".sound-on");
    this.soundOn.addEventListener("click", () => this.enableSound());
    /** The live view while connected (head-view.js), null otherwise. */
    this.headView = null;
    this.group = null;
    this.ownGroup = null;
    this.givenNodes = null;
    this.connected = false;
    this.restartQueued = false;
  }

  /** The connection's state: connecting, waiting, live, ended, reconnecting or error. */
  get state() {
    return this.headView?.state ?? "closed";
  }

  /** The camera the element is seen through: its group's. */
  get camera() {
    return this.group.camera;
  }

  /** The sound the element's frames wait for and its voice plays on: its group's, or null. */
  get sound() {
    return this.group?.sound ?? null;
  }

  /**
   * The nodes sockets and fetches go to (nodes.js): the ones set here (a page that already
   * has a list shares it), else the `server` attribute's, else the module's own server.
   */
  get nodes() {
    if (this.givenNodes) {
      return this.givenNodes;
    }
    const listed = parseNodes(this.getAttribute("server"));
    return new Nodes(listed.length > 0 ? listed : [new URL(import.meta.url).origin], location);
  }

  set nodes(nodes) {
    this.givenNodes = nodes;
    this.restart();
  }

  connectedCallback() {
    this.connected = true;
    if (!this.group) {
      this.ownGroup = new HeadGroup({ camera: new OrbitCamera() });
      this.ownGroup.add(this);
    }
    this.restart();
  }

  disconnectedCallback() {
    this.connected = false;
    this.stop();
    this.group?.remove(this);
    this.group = null;
    this.ownGroup = null;
  }

  /** Called by HeadGroup.add: the element is drawn by `group` from now on, and leaves its last. */
  joinGroup(group) {
    if (this.group && this.group !== group) {
      this.group.remove(this);
    }
    const soundChanged = this.group?.sound !== group.sound;
    this.group = group;
    if (group !== this.ownGroup) {
      this.ownGroup = null;
    }
    if (soundChanged) {
      this.restart();
    }
  }

  attributeChangedCallback(name, old, value) {
    if (old === value || !this.connected) {
      return;
    }
    if (DRAWING_ATTRIBUTES.has(name)) {
      if (this.headView) {
        this.applyDrawing(name);
      }
    } else {
      this.restart();
    }
  }

  /**
   * Connects again with the attributes as they are, once for all the changes made in one
   * go (a page setting head, stream and algo together reconnects once).
   */
  restart() {
    if (!this.connected || this.restartQueued) {
      return;
    }
    this.restartQueued = true;
    queueMicrotask(() => {
      this.restartQueued = false;
      if (this.connected) {
        this.stop();
        this.start();
      }
    });
  }

  /** How the head is looked at, from `view` and `cut`. */
  look() {
    return { mode: this.getAttribute("view") ?? "front", cutDeg: Number(this.getAttribute("cut") ?? 0) };
  }

  /** The heat-map asked for: `roughness`, `folds` or null. */
  heat() {
    const heat = this.getAttribute("heat");
    return HEAT_KINDS.includes(heat) ? heat : null;
  }

  /** The heat-map ramp's top: degrees for folds, else the `heatmax` roughness. */
  heatScale() {
    if (this.heat() === "folds") {
      return FOLDS_RAMP_TOP_DEG;
    }
    const max = Number(this.getAttribute("heatmax"));
    return this.hasAttribute("heatmax") && max > 0 && Number.isFinite(max) ? max : DEFAULT_HEAT_MAX;
  }

  /** The codec the voice is asked in, or null. */
  audio() {
    const codec = this.getAttribute("audio");
    return AUDIO_CODECS.includes(codec) ? codec : null;
  }

  /** Applies a drawing attribute (or all of them) to the live view, without reconnecting. */
  applyDrawing(name = null) {
    const view = this.headView;
    if (!name || name === "view" || name === "cut") {
      view.setLook(this.look());
    }
    if (!name || name === "lips" || name === "lipstrength") {
      const strength = Number(this.getAttribute("lipstrength") ?? 1);
      view.setLips({
        mode: this.getAttribute("lips") ?? "tint",
        strength: Number.isFinite(strength) ? Math.max(0, Math.min(1, strength)) : 1,
      });
    }
    if (!name || name === "heatmax") {
      view.setHeatScale(this.heatScale());
    }
    // The element's own camera follows `mouth`; only a change moves it, so a reconnect
    // keeps where the viewer turned it.
    const closeUp = this.hasAttribute("mouth");
    if ((name === "mouth" || (!name && this.ownGroup)) && this.camera.closeUp !== closeUp) {
      this.camera.setCloseUp(closeUp);
    }
  }

  /**
   * A new canvas for a new view: a canvas whose WebGL context was given back (the last
   * view's, on a reconnect with other attributes) cannot draw again. Drag, pinch, wheel and
   * keys move the group's camera.
   */
  newCanvas() {
    this.canvas?.remove();
    const canvas = document.createElement("canvas");
    canvas.tabIndex = 0;
    canvas.setAttribute("role", "img");
    attachPointerControls(canvas, () => this.camera);
    canvas.addEventListener("keydown", (event) => {
      if (handleCameraKey(event, this.camera)) {
        event.preventDefault();
      }
    });
    this.shadowRoot.prepend(canvas);
    this.canvas = canvas;
  }

  start() {
    if (!this.connected || !this.group) {
      return;
    }
    this.newCanvas();
    const head = this.getAttribute("head");
    const replay = this.getAttribute("replay");
    const what = replay ? `replaying ${replay}` : "live";
    this.canvas.setAttribute("aria-label", `The head ${head ?? ""}, ${what}. Arrow keys turn it, + and − zoom, 0 resets.`);
    if (!head) {
      this.fail({ message: "no head: give the element a head attribute", kind: "refused" });
      return;
    }
    const audio = this.audio();
    if (audio && this.ownGroup && !this.ownGroup.sound) {
      this.ownGroup.sound = new Sound({ onChange: () => this.showSoundButton() });
    }
    const nodes = this.nodes;
    const tell = (name, detail) => this.dispatchEvent(new CustomEvent(name, { detail }));
    try {
      this.headView = this.newHeadView(nodes, audio, tell);
    } catch (error) {
      this.fail({ message: `the 3D view cannot start: ${error.message}`, kind: "refused" });
      return;
    }
    this.applyDrawing();
    this.showSoundButton();
    this.headView.connect({
      head,
      stream: this.getAttribute("stream") ?? "main",
      replay,
      algorithm: this.getAttribute("algo") ?? "",
      heat: this.heat(),
      token: this.getAttribute("token") ?? "",
    });
  }

  /** The live view on this element's canvas, telling what happens as events. */
  newHeadView(nodes, audio, tell) {
    const absolute = (url) => new URL(nodes.httpUrl(url), location.href).href;
    return new HeadView({
      canvas: this.canvas,
      nodes,
      loadMesh: (url) => cached(absolute(url), () => nodes.fetch(url), parseMesh),
      loadWeights: (url, vertexCount) =>
        cached(absolute(url), () => nodes.fetch(url), (buffer) => parseVertexWeights(buffer, vertexCount)),
      sound: this.sound,
      audio: this.sound ? audio : null,
      handlers: {
        onState: (state, detail) => this.stateChanged(state, detail),
        onSnapshot: (snapshot) => tell("snapshot", { snapshot }),
        onMesh: (url, mesh, mouth) => {
          this.group.frameMesh(url, mesh, mouth);
          tell("mesh", { url, mesh, mouth });
        },
        onParts: (parts, eyes) => tell("parts", { parts, eyes, loaded: false }),
        onPartsLoaded: () => tell("parts", { parts: null, eyes: null, loaded: true }),
        onLips: (status) => tell("lips", { status }),
        onFrameHeader: (header, buffer, arrivalUs) => tell("arrival", { header, bytes: buffer.byteLength, arrivalUs }),
        onSkipped: (count) => tell("skipped", { count }),
        onAudio: ({ bytes }) => tell("audio", { bytes }),
        onReplay: (message) => tell("replay", { message }),
        onShown: (frame, said) => {
          this.saidLine.textContent = said ?? "";
          tell("frame", { seq: frame.seq, t: frame.producerTimeS, said, frame });
        },
        onProblem: (message) => tell("error", { message, kind: "problem" }),
      },
    });
  }

  stop() {
    this.headView?.destroy();
    this.headView = null;
  }

  /** Steers a replay (proto/PROTOCOL.md, "Recordings and replay"); false when not sent. */
  control(message) {
    return this.headView?.control(message) ?? false;
  }

  /** Draws when something changed or `force` (the group calls it once per animation frame). */
  draw(force) {
    if (!this.headView) {
      return;
    }
    this.headView.draw(this.camera, force);
    this.showScale(this.headView.renderer.cssPixelsPerMm);
  }

  /**
   * The scale bar of the side and cut-away looks: the shortest of SCALE_LENGTHS_MM that
   * is at least SCALE_MIN_PX CSS pixels long at the cut plane; hidden in the other looks.
   */
  showScale(pixelsPerMm) {
    const mm = pixelsPerMm ? SCALE_LENGTHS_MM.find((l) => l * pixelsPerMm >= SCALE_MIN_PX) : undefined;
    this.scale.hidden = mm === undefined;
    if (mm === undefined) {
      return;
    }
    const width = `${(mm * pixelsPerMm).toFixed(1)}px`;
    if (this.scaleBar.style.width !== width) {
      this.scaleBar.style.width = width;
      this.scaleBar.dataset.mm = String(mm);
      this.scaleLabel.textContent = `${mm} mm`;
    }
  }

  /** The Sound on button shows while the element's own sound waits for a click. */
  showSoundButton() {
    const own = this.ownGroup?.sound;
    this.soundOn.hidden = !own || !this.audio() || own.playing;
  }

  async enableSound() {
    const sound = this.ownGroup?.sound;
    if (!sound) {
      return;
    }
    try {
      await sound.enable();
      sound.setMuted(false);
    } catch (error) {
      this.dispatchEvent(
        new CustomEvent("error", { detail: { message: `the sound cannot start: ${error.message}`, kind: "problem" } }),
      );
    }
    this.showSoundButton();
  }

  stateChanged(state, detail) {
    this.setAttribute("state", state);
    this.statusLine.textContent = state === "error" ? `Error: ${detail.message}` : STATUS_TEXT[state] ?? state;
    this.dispatchEvent(new CustomEvent("state", { detail: { state, ...detail } }));
    if (state === "ended") {
      this.dispatchEvent(new CustomEvent("end", { detail: { message: detail.message } }));
    } else if (state === "error") {
      this.dispatchEvent(
        new CustomEvent("error", { detail: { message: detail.message, code: detail.code, kind: "refused" } }),
      );
    }
  }

  /** An element that cannot start says why, as a refusal does. */
  fail(detail) {
    this.setAttribute("state", "error");
    this.statusLine.textContent = `Error: ${detail.message}`;
    this.dispatchEvent(new CustomEvent("state", { detail: { state: "error", ...detail } }));
    this.dispatchEvent(new CustomEvent("error", { detail }));
  }
}

if (!customElements.get("facewire-head")) {
  customElements.define("facewire-head", FacewireHead);
}
