// stream.js: one viewer WebSocket and its life. States: connecting; waiting (snapshot in,
// no frame yet); live; ended (the server sent `end`); reconnecting (exponential backoff
// after a lost connection: the server sends the newest frame right after its snapshot, so
// a reconnect resumes where the stream is now, with no replay); and error, for refusals
// that retrying cannot fix (codes.js: unknown head, bad algorithm, failed registration),
// which keep the server's `error` message, and for a snapshot naming a frame layout the
// page does not read (it asks for FWF2). A deleted head (close 4410) is reconnected to,
// so a head registered again under the same id shows up. The URL comes from a function
// asked again after every lost connection, so the page can move to another node
// (nodes.js); the backoff starts over once a node sends its snapshot.

import { END_REASONS, FINAL_CLOSE_CODES } from "./codes.js";

const FIRST_RETRY_MS = 500;
/** The first bytes of an audio chunk; every other binary message is a frame. */
const AUDIO_MAGIC = [0x46, 0x57, 0x41, 0x31]; // "FWA1"

function isAudio(buffer) {
  const head = new Uint8Array(buffer, 0, Math.min(4, buffer.byteLength));
  return head.length === 4 && AUDIO_MAGIC.every((b, i) => head[i] === b);
}
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
   * `handlers`: onSnapshot(snapshot), onFrame(ArrayBuffer, arrivalUs), onAudio(ArrayBuffer)
   * for an audio chunk (asked for with `audio=`), onReplay(message) for a replay's state
   * (proto/PROTOCOL.md, "Recordings and replay"), and onState(state, detail) where detail
   * is { message, code, retryMs } as far as known.
   */
  constructor(handlers) {
    this.handlers = handlers;
    this.socket = null;
    this.timer = 0;
    this.state = "closed";
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
    if (this.socket?.readyState !== WebSocket.OPEN) {
      return false;
    }
    this.socket.send(JSON.stringify(message));
    return true;
  }

  close() {
    clearTimeout(this.timer);
    if (this.socket) {
      const socket = this.socket;
      this.socket = null;
      socket.close(1000, "viewer closed");
    }
    this.state = "closed";
  }

  setState(state, detail = {}) {
    this.state = state;
    this.handlers.onState(state, detail);
  }

  connect() {
    this.setState("connecting");
    const socket = new WebSocket(this.url);
    socket.binaryType = "arraybuffer";
    this.socket = socket;
    let refusal = null;
    socket.onmessage = (event) => {
      if (socket !== this.socket) {
        return;
      }
      if (typeof event.data !== "string" && isAudio(event.data)) {
        this.handlers.onAudio?.(event.data);
        return;
      }
      if (typeof event.data !== "string") {
        const arrivalUs = Date.now() * 1000;
        if (this.state !== "live") {
          this.setState("live");
        }
        this.handlers.onFrame(event.data, arrivalUs);
        return;
      }
      let message;
      try {
        message = JSON.parse(event.data);
      } catch {
        return this.setState("error", { message: `unreadable message from the server: ${event.data.slice(0, 80)}` });
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
        refusal = message;
      }
    };
    socket.onclose = (event) => {
      if (socket !== this.socket) {
        return;
      }
      this.socket = null;
      const message = refusal ? `${refusal.message} (${refusal.code})` : event.reason || "connection lost";
      if (FINAL_CLOSE_CODES.has(event.code)) {
        this.setState("error", { message, code: event.code });
        return;
      }
      const retryMs = Math.min(MAX_RETRY_MS, FIRST_RETRY_MS * 2 ** this.attempt) * (0.8 + 0.4 * Math.random());
      this.attempt += 1;
      this.url = this.target(true);
      this.setState("reconnecting", { message, code: event.code, retryMs });
      this.timer = setTimeout(() => this.connect(), retryMs);
    };
  }
}
