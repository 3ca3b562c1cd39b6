// socket-pump.js: one viewer WebSocket read off the page's main thread. A worker
// (socket-worker.js) runs a SocketPump for each view: it opens, sends on and closes the
// socket as the page asks (stream.js keeps the states, retries and refusals), hands text
// and frames to the page as they come, and takes the voice's chunks ("FWA1") itself:
// decoded (Opus by WebCodecs' AudioDecoder, PCM as it comes) and posted straight to the
// audio thread (playout-worklet.js) through the port the sound gave it. The page's draws
// (50-70 ms each under a software GL) then delay neither the voice nor the timing of its
// arrival, which sets the playout delay.
//
// The pump also says when the voice's timeline starts over, in order with the chunks: at
// a snapshot (a new connection, rate 1), at a replay's `replay` message (sought, looped,
// paused or another speed: the replay's speed), and when a live stream's frames go back
// (a new producer: the rate kept); a port given later starts at the rate of the moment.

import { decodeAudio, OPUS_RATE, readFrameHeader } from "./decode.js";

/** The first bytes of an audio chunk; every other binary message is a frame. */
const AUDIO_MAGIC = [0x46, 0x57, 0x41, 0x31]; // "FWA1"

function isAudio(buffer) {
  const head = new Uint8Array(buffer, 0, Math.min(4, buffer.byteLength));
  return head.length === 4 && AUDIO_MAGIC.every((b, i) => head[i] === b);
}

export class SocketPump {
  /**
   * `post(event, transfer)`: to the page. Events, each with the `id` of the connection
   * they come from: `open`; `text` ({data}); `frame` ({data: ArrayBuffer, arrivalUs});
   * `audio` ({bytes, codec} or {bytes, problem}); `close` ({code, reason}).
   * `makeSocket(url)`: a WebSocket (tests give another).
   */
  constructor(post, makeSocket = (url) => new WebSocket(url)) {
    this.post = post;
    this.makeSocket = makeSocket;
    this.socket = null;
    this.id = null;
    this.sink = null;
    this.decoder = null;
    this.decoding = [];
    this.replayStream = false;
    this.lastSeq = null;
    /** The timeline's rate (a replay's speed), which a port given later starts with. */
    this.rate = 1;
  }

  /** A request from the page: `open` ({id, url}), `send` ({id, text}), `close` ({id, code, reason}) or `sink` ({port}). */
  handle(request) {
    if (request.op === "open") {
      this.open(request.id, request.url);
    } else if (request.op === "send") {
      if (request.id === this.id && this.socket?.readyState === 1) {
        this.socket.send(request.text);
      }
    } else if (request.op === "close") {
      if (request.id === this.id) {
        this.closeSocket(request.code, request.reason);
      }
    } else if (request.op === "sink") {
      this.sink = request.port ?? null;
      this.lastSeq = null;
      this.closeDecoder();
      this.toSink({ type: "restart", rate: this.rate });
    }
  }

  open(id, url) {
    this.closeSocket(1000, "viewer closed");
    this.id = id;
    this.lastSeq = null;
    let socket;
    try {
      socket = this.makeSocket(url);
    } catch (error) {
      this.post({ kind: "close", id, code: 1006, reason: `cannot open ${url}: ${error.message}` });
      return;
    }
    socket.binaryType = "arraybuffer";
    this.socket = socket;
    socket.onopen = () => socket === this.socket && this.post({ kind: "open", id });
    socket.onmessage = (event) => socket === this.socket && this.message(event.data);
    socket.onclose = (event) => {
      if (socket === this.socket) {
        this.socket = null;
        this.post({ kind: "close", id, code: event.code, reason: event.reason });
      }
    };
  }

  closeSocket(code, reason) {
    if (this.socket) {
      const socket = this.socket;
      this.socket = null;
      socket.close(code, reason);
    }
  }

  message(data) {
    const id = this.id;
    if (typeof data === "string") {
      this.timelineFromText(data);
      this.post({ kind: "text", id, data });
    } else if (isAudio(data)) {
      this.audio(data);
    } else {
      if (this.sink) {
        this.timelineFromFrame(data); // the page reads every header anyway; this one only for a voice
      }
      this.post({ kind: "frame", id, data, arrivalUs: Date.now() * 1000 }, [data]);
    }
  }

  /** A snapshot or a replay's state starts the voice's timeline over. */
  timelineFromText(text) {
    let message;
    try {
      message = JSON.parse(text);
    } catch {
      return; // the page says it is unreadable
    }
    if (message.type === "snapshot") {
      this.replayStream = Boolean(message.replay);
      this.lastSeq = null;
      this.restart(1);
    } else if (message.type === "replay") {
      this.restart(message.speed > 0 ? message.speed : 1);
    }
  }

  restart(rate) {
    this.rate = rate;
    this.toSink({ type: "restart", rate });
  }

  /** A live stream's frames going back: a new producer, on a new timeline. */
  timelineFromFrame(buffer) {
    let seq;
    try {
      seq = readFrameHeader(buffer).seq;
    } catch {
      return; // the page says it is unreadable
    }
    if (this.lastSeq !== null && seq <= this.lastSeq && !this.replayStream) {
      this.toSink({ type: "reset" });
    }
    this.lastSeq = seq;
  }

  toSink(message, transfer = []) {
    this.sink?.postMessage(message, transfer);
  }

  audio(buffer) {
    const bytes = buffer.byteLength;
    let chunk;
    try {
      chunk = decodeAudio(buffer);
    } catch (error) {
      this.post({ kind: "audio", id: this.id, bytes, problem: error.message });
      return;
    }
    this.post({ kind: "audio", id: this.id, bytes, codec: chunk.codec });
    if (!this.sink) {
      return; // nothing plays it yet: the sound starts with a click
    }
    if (chunk.codec === "pcm") {
      const floats = new Float32Array(chunk.samples.length);
      for (let i = 0; i < floats.length; i++) {
        floats[i] = chunk.samples[i] / 32768;
      }
      this.toPlayout(chunk, chunk.sampleRate, floats);
    } else {
      this.decodeOpus(chunk);
    }
  }

  decodeOpus(chunk) {
    if (typeof AudioDecoder === "undefined") {
      return; // the page asks for PCM where Opus cannot be decoded
    }
    if (!this.decoder) {
      this.decoder = new AudioDecoder({
        output: (data) => this.decoded(data),
        error: () => {
          this.decoder = null; // made anew at the next packet
          this.decoding = [];
        },
      });
      this.decoder.configure({ codec: "opus", sampleRate: OPUS_RATE, numberOfChannels: 1 });
    }
    // Outputs come in order: the queue keeps each packet's exact t and receipt.
    this.decoding.push(chunk);
    const timestamp = Math.round(chunk.t * 1e6);
    this.decoder.decode(new EncodedAudioChunk({ type: "key", timestamp, data: chunk.packet }));
  }

  decoded(data) {
    const chunk = this.decoding.shift();
    const floats = new Float32Array(data.numberOfFrames);
    data.copyTo(floats, { planeIndex: 0, format: "f32-planar" });
    const rate = data.sampleRate;
    data.close();
    if (chunk) {
      this.toPlayout(chunk, rate, floats);
    }
  }

  toPlayout(chunk, sampleRate, floats) {
    const { t, serverReceiveUs, codec } = chunk;
    this.toSink({ type: "chunk", t, sampleRate, floats, serverReceiveUs, codec }, [floats.buffer]);
  }

  closeDecoder() {
    if (this.decoder && this.decoder.state !== "closed") {
      this.decoder.close();
    }
    this.decoder = null;
    this.decoding = [];
  }
}
