// talk.js: the microphone as a producer. The Talk button asks for the microphone
// (getUserMedia), takes its samples at 48 kHz through an AudioWorklet (talk-worklet.js),
// and sends them as 20 ms PCM chunks (FWA1, proto/PROTOCOL.md) on a producer socket with
// `derive=visemes`: the server derives the face from the voice, and every viewer of the
// stream sees it. The chunks are timed by the samples sent (t = samples / 48000), the
// stream's own clock; stopping sends `end`.

/** The rate the microphone is taken at, Hz (one the wire accepts; Opus's own). */
export const TALK_RATE = 48_000;
/** Samples per chunk: 20 ms, as WebRTC sends them. */
const CHUNK_SAMPLES = 960;

/**
 * An FWA1 message holding one PCM chunk: `samples` (floats, -1..1) at `rate`, whose first
 * sample is at `tS` on the stream's clock.
 */
export function encodePcmChunk(tS, rate, samples) {
  const body = 8 + 2 * samples.length;
  const bytes = new ArrayBuffer(21 + 5 + body);
  const view = new DataView(bytes);
  [0x46, 0x57, 0x41, 0x31].forEach((b, i) => view.setUint8(i, b)); // "FWA1"
  view.setFloat64(4, tS, true);
  view.setBigUint64(12, 0n, true);
  view.setUint8(20, 1); // one section
  view.setUint8(21, 1); // kind 1: pcm
  view.setUint32(22, body, true);
  view.setUint32(26, rate, true);
  view.setUint32(30, samples.length, true);
  samples.forEach((s, i) => {
    const clamped = Math.max(-1, Math.min(1, s));
    view.setInt16(34 + 2 * i, Math.round(clamped * 32767), true);
  });
  return bytes;
}

export class Talk {
  /**
   * `onState(state, message)`: `starting`, `talking`, `stopped` or `error` (with why).
   */
  constructor({ onState }) {
    this.onState = onState;
    this.state = "stopped";
  }

  get talking() {
    return this.state === "talking" || this.state === "starting";
  }

  /** Starts talking into `url`, a producer socket URL (with `derive=visemes`). */
  async start(url) {
    this.stop();
    this.setState("starting");
    try {
      this.media = await navigator.mediaDevices.getUserMedia({
        audio: { channelCount: 1, echoCancellation: true, noiseSuppression: true },
      });
      this.context = new AudioContext({ sampleRate: TALK_RATE });
      await this.context.audioWorklet.addModule("/talk-worklet.js");
    } catch (error) {
      this.stop();
      this.setState("error", `the microphone cannot start: ${error.message}`);
      return;
    }
    const socket = new WebSocket(url);
    socket.binaryType = "arraybuffer";
    this.socket = socket;
    this.pending = new Float32Array(CHUNK_SAMPLES);
    this.filled = 0;
    this.sent = 0;
    socket.onmessage = (event) => {
      if (typeof event.data !== "string") {
        return;
      }
      const message = JSON.parse(event.data);
      if (message.type === "error") {
        this.refusal = `${message.message} (${message.code})`;
      }
    };
    socket.onclose = (event) => {
      if (socket !== this.socket) {
        return;
      }
      const why = this.refusal ?? event.reason ?? "";
      this.stop();
      if (event.code !== 1000) {
        this.setState("error", `the server closed the microphone's stream: ${why || event.code}`);
      }
    };
    socket.onopen = () => {
      if (socket !== this.socket) {
        return;
      }
      const source = this.context.createMediaStreamSource(this.media);
      this.tap = new AudioWorkletNode(this.context, "facewire-microphone");
      this.tap.port.onmessage = (event) => this.take(event.data);
      // Silent, but pulled by the destination so that the tap runs in every browser.
      const silent = this.context.createGain();
      silent.gain.value = 0;
      source.connect(this.tap).connect(silent).connect(this.context.destination);
      this.context.resume();
      this.setState("talking");
    };
  }

  /** Takes a block of samples; sends each 20 ms it completes. */
  take(block) {
    let at = 0;
    while (at < block.length && this.socket?.readyState === WebSocket.OPEN) {
      const n = Math.min(block.length - at, CHUNK_SAMPLES - this.filled);
      this.pending.set(block.subarray(at, at + n), this.filled);
      this.filled += n;
      at += n;
      if (this.filled === CHUNK_SAMPLES) {
        this.socket.send(encodePcmChunk(this.sent / TALK_RATE, TALK_RATE, this.pending));
        this.sent += CHUNK_SAMPLES;
        this.filled = 0;
      }
    }
  }

  /** Stops: ends the stream (its viewers get `end`) and gives the microphone back. */
  stop() {
    const socket = this.socket;
    this.socket = null;
    if (socket?.readyState === WebSocket.OPEN) {
      socket.send(JSON.stringify({ type: "end" }));
      socket.close(1000, "talk stopped");
    } else {
      socket?.close();
    }
    this.tap?.disconnect();
    this.tap = null;
    this.media?.getTracks().forEach((track) => track.stop());
    this.media = null;
    this.context?.close();
    this.context = null;
    this.refusal = null;
    if (this.state !== "stopped") {
      this.setState("stopped");
    }
  }

  setState(state, message = "") {
    this.state = state;
    this.onState(state, message);
  }
}
