// facewire-head.js: the live head as a component any page can embed, with two lines:
//
//   <script type="module" src="http://HOST:8480/facewire-head.js"></script>
//   <facewire-head head="ict" stream="main" view="front"></facewire-head>
//
// A custom element with its own canvas, camera (drag, pinch, wheel and keys, as on the
// page) and socket, built on the same view as the facewire page (head-view.js: the same
// decoding, the same drawing). Attributes, each read again when it changes:
// - `server`: the facewire server's base URL, or several nodes of a cluster
//   comma-separated (the element fails over between them as the page does); by default
//   the server this module was loaded from;
// - `head` (required) and `stream` (default `main`);
// - `view`: `front` (default), `side`, `cutaway` or `see-through`, and `cut`, the
//   cut-away's turn in degrees;
// - `algo`: a letter or spec (default: the server's);
// - `lips`: `tint` (default), `contrast`, `region` or `off`;
// - `mouth`: present for the mouth close-up;
// - `token`: a viewer token.
// Events: `frame` (detail: `seq`, `t`, `said`, the label or viseme shown, and `frame`, the
// decoded frame), `end` (detail: `message`: the stream ended; the element waits for it to
// start again) and `error` (detail: `message`, `code`: a refusal or an unreadable message;
// a refusal that retrying cannot fix stops the element until an attribute changes). The
// `state` property and the `state` attribute say `connecting`, `waiting`, `live`,
// `ended`, `reconnecting` or `error`. No sound: a page that wants the voice uses the
// facewire page or the protocol (proto/PROTOCOL.md).

import { attachPointerControls, handleCameraKey, OrbitCamera } from "./camera.js";
import { parseVertexWeights, parseMesh } from "./decode.js";
import { HeadView } from "./head-view.js";
import { Nodes, parseNodes } from "./nodes.js";

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
`;

const STATUS_TEXT = {
  connecting: "Connecting",
  waiting: "Waiting for frames",
  live: "",
  ended: "The stream ended; waiting for it to start again",
  reconnecting: "Reconnecting",
  error: "Error",
};

/** Meshes and lip weights by absolute URL, shared by every element on the page. */
const cache = new Map();

function cached(url, parse) {
  if (!cache.has(url)) {
    const promise = fetch(url).then((response) => {
      if (!response.ok) {
        throw new Error(`HTTP ${response.status}`);
      }
      return response.arrayBuffer().then(parse);
    });
    promise.catch(() => cache.delete(url));
    cache.set(url, promise);
  }
  return cache.get(url);
}

export class FacewireHead extends HTMLElement {
  static observedAttributes = ["server", "head", "stream", "view", "cut", "algo", "lips", "mouth", "token"];

  constructor() {
    super();
    const root = this.attachShadow({ mode: "open" });
    root.innerHTML = `<style>${STYLE}</style>
      <span class="said" aria-live="off"></span><span class="status" role="status"></span>`;
    this.canvas = null;
    this.saidLine = root.querySelector(".said");
    this.statusLine = root.querySelector(".status");
    this.camera = new OrbitCamera();
    this.camera.onChange(() => {
      this.cameraMoved = true;
    });
    this.view = null;
    this.frame = null;
    this.framed = null;
    this.drawing = 0;
  }

  /** The connection's state: connecting, waiting, live, ended, reconnecting or error. */
  get state() {
    return this.view?.state ?? "closed";
  }

  connectedCallback() {
    this.start();
  }

  disconnectedCallback() {
    this.stop();
  }

  attributeChangedCallback(name, old, value) {
    if (old === value || !this.view) {
      return;
    }
    if (name === "view" || name === "cut") {
      this.view.setLook(this.look());
    } else if (name === "lips") {
      this.view.setLips({ mode: this.getAttribute("lips") ?? "tint", strength: 1 });
    } else if (name === "mouth") {
      this.camera.setCloseUp(this.hasAttribute("mouth"));
    } else {
      this.stop();
      this.start();
    }
  }

  look() {
    return { mode: this.getAttribute("view") ?? "front", cutDeg: Number(this.getAttribute("cut") ?? 0) };
  }

  /** The nodes to talk to: the `server` attribute's, else the server of this module. */
  nodes() {
    const listed = parseNodes(this.getAttribute("server"));
    return new Nodes(listed.length > 0 ? listed : [new URL(import.meta.url).origin], location);
  }

  /**
   * A new canvas for a new view: a canvas whose WebGL context was given back (the last
   * view's, on a reconnect with other attributes) cannot draw again.
   */
  newCanvas() {
    this.canvas?.remove();
    const canvas = document.createElement("canvas");
    canvas.tabIndex = 0;
    canvas.setAttribute("role", "img");
    attachPointerControls(canvas, this.camera);
    canvas.addEventListener("keydown", (event) => {
      if (handleCameraKey(event, this.camera)) {
        event.preventDefault();
      }
    });
    this.shadowRoot.prepend(canvas);
    this.canvas = canvas;
  }

  start() {
    this.newCanvas();
    const head = this.getAttribute("head");
    this.canvas.setAttribute("aria-label", `The head ${head ?? ""}, live. Arrow keys turn it, + and − zoom, 0 resets.`);
    if (!head) {
      this.fail({ message: "no head: give the element a head attribute" });
      return;
    }
    const nodes = this.nodes();
    const absolute = (url) => new URL(nodes.httpUrl(url), location.href).href;
    this.view = new HeadView({
      canvas: this.canvas,
      nodes,
      loadMesh: (url) => cached(absolute(url), parseMesh),
      loadWeights: (url, vertexCount) => cached(absolute(url), (buffer) => parseVertexWeights(buffer, vertexCount)),
      handlers: {
        onState: (state, detail) => this.stateChanged(state, detail),
        onMesh: (url, mesh, mouth) => {
          if (this.framed !== url) {
            this.framed = url;
            this.camera.frame(mesh.positions, mesh.mmPerUnit, mouth);
            this.camera.setCloseUp(this.hasAttribute("mouth"));
          }
        },
        onShown: (frame, said) => {
          this.saidLine.textContent = said ?? "";
          this.dispatchEvent(
            new CustomEvent("frame", { detail: { seq: frame.seq, t: frame.producerTimeS, said, frame } }),
          );
        },
        onProblem: (message) => this.dispatchEvent(new CustomEvent("error", { detail: { message } })),
      },
    });
    this.view.setLook(this.look());
    this.view.setLips({ mode: this.getAttribute("lips") ?? "tint", strength: 1 });
    this.view.connect({
      head,
      stream: this.getAttribute("stream") ?? "main",
      algorithm: this.getAttribute("algo") ?? "",
      token: this.getAttribute("token") ?? "",
    });
    const loop = () => {
      this.drawing = requestAnimationFrame(loop);
      this.tick();
    };
    this.drawing = requestAnimationFrame(loop);
  }

  stop() {
    cancelAnimationFrame(this.drawing);
    this.view?.destroy();
    this.view = null;
    this.framed = null;
  }

  /** One animation frame: decode and show the newest frame (one at a time), then draw. */
  tick() {
    const view = this.view;
    if (!this.decoding) {
      const pending = view.prepare({ seq: view.newestSeq() });
      if (pending) {
        this.decoding = true;
        pending.then((frame) => {
          this.decoding = false;
          if (frame && view === this.view) {
            view.show(frame);
          }
        });
      }
    }
    view.draw(this.camera, this.cameraMoved);
    this.cameraMoved = false;
  }

  stateChanged(state, detail) {
    this.setAttribute("state", state);
    this.statusLine.textContent = state === "error" ? `Error: ${detail.message}` : STATUS_TEXT[state] ?? state;
    if (state === "ended") {
      this.dispatchEvent(new CustomEvent("end", { detail: { message: detail.message } }));
    } else if (state === "error") {
      this.dispatchEvent(new CustomEvent("error", { detail: { message: detail.message, code: detail.code } }));
    }
  }

  /** An element that cannot start says why, as a refusal does. */
  fail(detail) {
    this.setAttribute("state", "error");
    this.statusLine.textContent = `Error: ${detail.message}`;
    this.dispatchEvent(new CustomEvent("error", { detail }));
  }
}

if (!customElements.get("facewire-head")) {
  customElements.define("facewire-head", FacewireHead);
}
