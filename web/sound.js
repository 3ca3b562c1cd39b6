// sound.js: the stream's voice in the page, and the clock the views draw by. The voice
// is played on the audio thread: an AudioWorklet (playout-worklet.js) keeps a jitter
// buffer (playout.js) that views' sockets (socket-pump.js, off the main thread) feed with
// decoded chunks through MessagePorts this sound hands them (addSource), and places each
// chunk at `t / rate + offset` on one AudioContext's clock, after a playout delay that
// follows the jitter of their arrival, plus what the face needs on a page slow to draw
// (tuneFace: the voice waits for the face). A replay played slower or faster sends its voice
// stretched at the same pitch: `rate` stream seconds go by per second heard. The worklet
// tells this sound where each piece went; heardTime() tells which stream time is coming out
// of the speakers now (getOutputTimestamp, else currentTime less outputLatency): the views
// draw the frame of that time, so the face is seen when its sound is heard. The browser
// starts an AudioContext only after a click (its autoplay rule): until enable(), nothing
// plays and the views draw frames as they arrive.

import { OPUS_RATE } from "./decode.js";
import { quantile } from "./quantile.js";

/** Scheduled pieces remembered for heardTime (about 10 s of 20 ms chunks). */
const KEEP_PIECES = 500;
/** The face is let be this late at the 95th percentile before the voice waits for it, ms. */
const FACE_LATE_AIM_MS = 20;
/** Of the face's lateness beyond the aim, the share added to the delay each time, and back. */
const FACE_GAIN = 0.5;
/** The most the voice waits for the face, seconds. */
const MAX_FACE_EXTRA_S = 0.5;
/** Fewer frames shown since the last tuning and it waits; more are not kept. */
const FACE_SHOWN_ENOUGH = 5;
const FACE_SHOWN_KEPT = 1000;
/** The face's extra is told again when it moves by this much, seconds. */
const FACE_EXTRA_STEP_S = 0.005;
/** Drawn frames whose distance from their sound is kept (logSync): 10 min of 30 fps. */
const SYNC_LOG = 18000;
/** Times closer than this are one, seconds. */
const EPSILON_S = 1e-6;

/** The codec the page asks for: "opus" where WebCodecs decodes Opus here, else "pcm". */
export async function audioCodec() {
  if (typeof AudioDecoder === "undefined") {
    return "pcm";
  }
  try {
    const { supported } = await AudioDecoder.isConfigSupported({ codec: "opus", sampleRate: OPUS_RATE, numberOfChannels: 1 });
    return supported ? "opus" : "pcm";
  } catch {
    return "pcm";
  }
}

export class Sound {
  /** `onChange()`: the state or the numbers changed (for the page's controls). */
  constructor({ onChange = () => {} } = {}) {
    this.onChange = onChange;
    this.context = null;
    this.gain = null;
    this.node = null;
    this.starting = null;
    this.volume = 1;
    this.muted = false;
    this.syncLog = [];
    /** The sockets that feed the voice (stream.js ViewerSocket: setAudioSink(port)). */
    this.sources = new Set();
    /** Where the pieces of the voice were placed, from the worklet: {start, end, t, rate, serverReceiveUs}. */
    this.pieces = [];
    /** The jitter buffer's numbers (playout.js), from the worklet. */
    this.numbers = null;
    /** Stream seconds per second heard: 1 but for a replay played slower or faster. */
    this.rate = 1;
    /** How late each frame shown since the last tuning was for its sound, ms (drawn minus heard). */
    this.faceLateMs = [];
    /** More delay than the jitter's that the face needs, as told to the worklet, seconds. */
    this.faceExtraS = 0;
  }

  /** True once a click started the context and the voice can play. */
  get playing() {
    return this.node !== null && this.context.state === "running";
  }

  /** The codec of the chunks playing, once one has. */
  get codec() {
    return this.numbers?.codec ?? null;
  }

  /** A socket that carries the voice: given a port to the audio thread once one exists. */
  addSource(source) {
    this.sources.add(source);
    if (this.node) {
      this.connectSource(source);
    }
  }

  removeSource(source) {
    if (this.sources.delete(source) && this.node) {
      source.setAudioSink(null);
    }
  }

  connectSource(source) {
    const channel = new MessageChannel();
    this.node.port.postMessage({ source: channel.port1 }, [channel.port1]);
    source.setAudioSink(channel.port2);
  }

  /** The user's click: starts (or resumes) the context and its playout. Returns a promise. */
  async enable() {
    this.starting ??= this.start().catch((error) => {
      this.context?.close();
      this.context = null; // the next click tries again
      this.starting = null;
      throw error;
    });
    await this.starting;
    await this.context.resume();
    this.onChange();
  }

  async start() {
    // 48 kHz, the rate Opus decodes at: the worklet then copies the default voice as it comes.
    this.context = new AudioContext({ latencyHint: "interactive", sampleRate: OPUS_RATE });
    this.gain = this.context.createGain();
    this.gain.connect(this.context.destination);
    this.applyVolume();
    this.context.onstatechange = () => this.onChange();
    await this.context.audioWorklet.addModule(new URL("./playout-worklet.js", import.meta.url));
    this.node = new AudioWorkletNode(this.context, "facewire-playout", { numberOfInputs: 0, outputChannelCount: [1] });
    this.node.connect(this.gain);
    this.node.port.onmessage = ({ data }) => this.fromPlayout(data);
    for (const source of this.sources) {
      this.connectSource(source);
    }
  }

  /** The worklet's news: a piece placed (with the numbers), or the timeline started over. */
  fromPlayout({ piece, numbers, restarted }) {
    if (restarted !== undefined) {
      this.pieces = [];
      this.rate = restarted;
      return;
    }
    this.numbers = numbers;
    if (numbers) {
      this.rate = numbers.rate;
    }
    if (piece) {
      this.pieces.push(piece);
      if (this.pieces.length > KEEP_PIECES) {
        this.pieces.shift();
      }
    }
  }

  /** A frame was drawn `lateMs` after its sound was heard (negative: before). */
  faceShown(lateMs) {
    this.faceLateMs.push(lateMs);
    if (this.faceLateMs.length > FACE_SHOWN_KEPT) {
      this.faceLateMs.shift();
    }
  }

  /**
   * Tunes how much longer than the jitter asks the voice waits for the face, from how late
   * the frames drawn since the last call were (a controller called about once a second):
   * their 95th percentile is brought to FACE_LATE_AIM_MS, half the difference at a time,
   * so a page that draws slowly delays the voice until its face keeps up, and one that
   * draws in time takes the delay back.
   */
  tuneFace() {
    if (!this.node || this.faceLateMs.length < FACE_SHOWN_ENOUGH) {
      return;
    }
    const late = quantile(this.faceLateMs, 0.95);
    this.faceLateMs = [];
    const extra = Math.min(MAX_FACE_EXTRA_S, Math.max(0, this.faceExtraS + (FACE_GAIN * (late - FACE_LATE_AIM_MS)) / 1000));
    if (Math.abs(extra - this.faceExtraS) >= FACE_EXTRA_STEP_S || (extra === 0 && this.faceExtraS !== 0)) {
      this.faceExtraS = extra;
      this.node.port.postMessage({ faceExtraS: extra });
    }
  }

  setVolume(volume) {
    this.volume = Math.min(1, Math.max(0, volume));
    this.applyVolume();
  }

  setMuted(muted) {
    this.muted = muted;
    this.applyVolume();
    this.onChange();
  }

  applyVolume() {
    if (this.gain) {
      this.gain.gain.value = this.muted ? 0 : this.volume;
    }
  }

  /** The context time being heard at `perfNow` (performance.now() milliseconds). */
  outputContextTime(perfNow) {
    const context = this.context;
    const stamp = context.getOutputTimestamp?.();
    if (stamp && stamp.performanceTime > 0) {
      return stamp.contextTime + (perfNow - stamp.performanceTime) / 1000;
    }
    return context.currentTime - (context.outputLatency || context.baseLatency || 0);
  }

  /** performance.now() milliseconds at which context time `contextTime` is heard. */
  heardAtMs(contextTime) {
    const now = performance.now();
    return now + (contextTime - this.outputContextTime(now)) * 1000;
  }

  /**
   * The stream time being heard at `perfNow`, or null when no voice plays: from the piece
   * of audio playing then (each piece keeps the offset it was scheduled with).
   */
  heardTime(perfNow) {
    if (!this.playing || this.pieces.length === 0) {
      return null;
    }
    const ctxTime = this.outputContextTime(perfNow);
    let piece = this.pieces[0];
    for (let i = this.pieces.length - 1; i >= 0; i--) {
      if (this.pieces[i].start <= ctxTime + EPSILON_S) {
        piece = this.pieces[i];
        break;
      }
    }
    return piece.t + (ctxTime - piece.start) * piece.rate;
  }

  /**
   * performance.now() milliseconds at which stream time `t` is (or was) heard, from the
   * piece of audio that holds it; null when no piece does.
   */
  heardAtMsForTime(t) {
    if (!this.playing) {
      return null;
    }
    const piece = this.pieces.findLast((p) => p.t <= t + EPSILON_S && t < p.t + (p.end - p.start) * p.rate);
    return piece ? this.heardAtMs(piece.start + (t - piece.t) / piece.rate) : null;
  }

  /**
   * Keeps, for tests and the curious, each drawn frame's distance from its sound: the last
   * SYNC_LOG entries of {view, seq, t, label, offsetMs} (drawn minus heard, ms).
   */
  logSync(view, frame, offsetMs) {
    this.syncLog.push({ view, seq: frame.seq, t: frame.producerTimeS, label: frame.label, offsetMs });
    if (this.syncLog.length > SYNC_LOG) {
      this.syncLog.shift();
    }
  }

  /** Milliseconds from the server's receipt of the sound being heard now to now (wall clock). */
  earLatencyMs(perfNow) {
    const ctxTime = this.outputContextTime(perfNow);
    const piece = this.pieces.findLast((p) => p.start <= ctxTime);
    if (!piece) {
      return null;
    }
    return performance.timeOrigin + perfNow - piece.serverReceiveUs / 1000 - (ctxTime - piece.start) * 1000;
  }

  /** The numbers the page shows: delay and output latency (ms), late chunks so far. */
  summary(perfNow) {
    const numbers = this.numbers;
    if (!this.playing || !numbers) {
      return null;
    }
    const context = this.context;
    const output = context.outputLatency || context.baseLatency || 0;
    return {
      codec: numbers.codec,
      delayMs: numbers.delayS * 1000,
      targetMs: numbers.targetS * 1000,
      faceMs: numbers.faceExtraS * 1000,
      outputMs: output * 1000,
      earMs: this.earLatencyMs(perfNow),
      late: numbers.late,
      lowered: numbers.lowered,
    };
  }
}
