// stream.js: one viewer WebSocket and its life. States: connecting; waiting (snapshot in,
// no frame yet); live; ended (the server sent `end`); reconnecting (exponential backoff
// after a lost connection: the server sends the newest frame right after its snapshot, so
// a reconnect resumes where the stream is now, with no replay); and error, for refusals
// that retrying cannot fix (codes.js: unknown head, bad algorithm, failed registration),
// which keep the server's `error` message, and for a snapshot naming a frame layout the
// page does not read (it asks for FWF2). A deleted head (close 4410) is reconnected to,
// so a head registered again under the same id shows up. The URL comes from a function
// asked again after every lost connection, so the page can move to another node
// (nodes.js); the backoff starts over once a node sends its snapshot. The socket itself
// is read off the main thread (socket-thread.js), which takes the voice's chunks to the
// sound's audio thread and tells the page only how many bytes came.

import { END_REASONS, FINAL_CLOSE_CODES } from "./codes.js";
import { SocketThread } from "./socket-thread.js";

const FIRST_RETRY_MS = 500;
const MAX_RETRY_MS = 15_000;
/** The frame layout the page asks for (`format=`). */
export const VIEW_FORMAT = "fwf2";

/**
 * Why the snapshot's frames cannot be shown, or null: its `format` is fwf2, or absent (a
 * server from before FWF2, which sends FWF1: decode.js reads both).
 */
function formatProblem({ format }) {
  if (format === undefined || format === VIEW_FORMAT) {
    return null;
  }
  return `the server sends "${format}" frames, and this page reads only ${VIEW_FORMAT} (or FWF1 from a server that names no format)`;
}

export class ViewerSocket {
  /**
   * `handlers`: onSnapshot(snapshot), onFrame(ArrayBuffer, arrivalUs), onAudio({bytes,
   * codec} or {bytes, problem}) for an audio chunk (asked for with `audio=`), onReplay(message)
   * for a replay's state (proto/PROTOCOL.md, "Recordings and replay"), and onState(state,
   * detail) where detail is { message, code, retryMs } as far as known.
   */
  constructor(handlers) {
    this.handlers = handlers;
    this.thread = null;
    /** The current connection's number: events of an older one are ignored. */
    this.id = 0;
    this.connected = false;
    this.isOpen = false;
    this.refusal = null;
    this.timer = 0;
    this.state = "closed";
  }

  /** The socket's thread, started at first use. */
  pump(request, transfer = []) {
    this.thread ??= new SocketThread((event) => this.pumped(event));
    this.thread.request(request, transfer);
  }

  /** True when the socket is read in a worker, not on the page's main thread (socket-thread.js). */
  get offMainThread() {
    return Boolean(this.thread?.worker);
  }

  /** Where the voice's chunks go: a MessagePort to the sound's audio thread, or null. */
  setAudioSink(port) {
    this.pump({ op: "sink", port }, port ? [port] : []);
  }

  /**
   * Connects to `target`: a URL, or a function `target(lost)` that gives one, called with
   * false for the first attempt and with true after each lost connection (not after a
   * final refusal), before the wait, to pick the URL of the next attempt.
   */
  open(target) {
    this.close();
    this.target = typeof target === "function" ? target : () => target;
    this.url = this.target(false);
    this.attempt = 0;
    this.connect();
  }

  /** Sends `message` as JSON text (a replay's control), if the socket is open; true if sent. */
  send(message) {
    if (!this.isOpen) {
      return false;
    }
    this.pump({ op: "send", id: this.id, text: JSON.stringify(message) });
    return true;
  }

  close() {
    clearTimeout(this.timer);
    if (this.connected) {
      this.pump({ op: "close", id: this.id, code: 1000, reason: "viewer closed" });
    }
    this.id += 1;
    this.connected = false;
    this.isOpen = false;
    this.state = "closed";
  }

  /** Closes for good: the socket's thread stops. */
  destroy() {
    this.close();
    this.thread?.terminate();
    this.thread = null;
  }

  setState(state, detail = {}) {
    this.state = state;
    this.handlers.onState(state, detail);
  }

  connect() {
    this.setState("connecting");
    this.id += 1;
    this.connected = true;
    this.isOpen = false;
    this.refusal = null;
    this.pump({ op: "open", id: this.id, url: this.url });
  }

  /** What the socket's pump posted (socket-pump.js). */
  pumped(event) {
    if (event.id !== this.id || !this.connected) {
      return;
    }
    if (event.kind === "open") {
      this.isOpen = true;
    } else if (event.kind === "text") {
      this.text(event.data);
    } else if (event.kind === "frame") {
      if (this.state !== "live") {
        this.setState("live");
      }
      this.handlers.onFrame(event.data, event.arrivalUs);
    } else if (event.kind === "audio") {
      this.handlers.onAudio?.(event);
    } else if (event.kind === "close") {
      this.closed(event);
    }
  }

  text(data) {
    let message;
    try {
      message = JSON.parse(data);
    } catch {
      return this.setState("error", { message: `unreadable message from the server: ${data.slice(0, 80)}` });
    }
    if (message.type === "snapshot") {
      const problem = formatProblem(message);
      if (problem) {
        this.close();
        return this.setState("error", { message: problem });
      }
      this.attempt = 0;
      this.handlers.onSnapshot(message);
      this.setState("waiting");
    } else if (message.type === "replay") {
      this.handlers.onReplay?.(message);
    } else if (message.type === "end") {
      this.setState("ended", { message: END_REASONS[message.reason] || message.message || message.reason });
    } else if (message.type === "error") {
      this.refusal = message;
    }
  }

  closed({ code, reason }) {
    this.connected = false;
    this.isOpen = false;
    const refusal = this.refusal;
    const message = refusal ? `${refusal.message} (${refusal.code})` : reason || "connection lost";
    if (FINAL_CLOSE_CODES.has(code)) {
      this.setState("error", { message, code });
      return;
    }
    const retryMs = Math.min(MAX_RETRY_MS, FIRST_RETRY_MS * 2 ** this.attempt) * (0.8 + 0.4 * Math.random());
    this.attempt += 1;
    this.url = this.target(true);
    this.setState("reconnecting", { message, code, retryMs });
    this.timer = setTimeout(() => this.connect(), retryMs);
  }
}
