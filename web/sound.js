// sound.js: the stream's voice in the page, and the clock the views draw by. Audio chunks
// (decode.js decodeAudio) are decoded (Opus by WebCodecs' AudioDecoder; PCM as it comes)
// and scheduled on one AudioContext at `t + offset`, so the voice plays on the stream's
// own timeline after a playout delay. A replay played slower or faster (restart(rate))
// sends its voice stretched at the same pitch, each chunk stamped with the recording time
// of its first sample: `rate` stream seconds go by per second heard, and every place and
// length on the stream's timeline is divided by it. The delay follows the jitter of the chunks'
// arrival: it is the spread of their transit times (95th percentile above the fastest)
// plus a margin, raised at once when a chunk comes too late to play, and lowered only in
// a quiet chunk (a pause between words), so speech is never cut. heardTime() tells which
// stream time is coming out of the speakers now (getOutputTimestamp, else currentTime less
// outputLatency): the views draw the frame of that time, so the face is seen when its
// sound is heard. The browser starts an AudioContext only after a click (its autoplay
// rule): until enable(), nothing plays and the views draw frames as they arrive.

import { OPUS_RATE } from "./decode.js";

/** The playout delay never goes below this or above that, seconds. */
const MIN_DELAY_S = 0.06;
const MAX_DELAY_S = 1.0;
/** Above the arrival jitter: room for a late chunk, seconds. */
const DELAY_MARGIN_S = 0.03;
/** A chunk must be scheduled at least this far ahead of the context's clock, seconds. */
const SCHEDULE_AHEAD_S = 0.005;
/** Transit times kept for the jitter estimate: 10 s of 20 ms chunks. */
const TRANSIT_WINDOW = 500;
/** The delay is lowered when it exceeds its target by this much, in a quiet chunk, seconds. */
const LOWER_BY_OVER_S = 0.02;
/** A chunk whose RMS is below this (of full scale) is quiet. */
const QUIET_RMS = 0.01;
/** Scheduled pieces remembered for heardTime (about 10 s of 20 ms chunks). */
const KEEP_PIECES = 500;
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

/** The p-quantile (0..1) of numbers, by sorting a copy; undefined for none. */
export function quantile(values, p) {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))];
}

function rms(floats) {
  let sum = 0;
  for (const x of floats) {
    sum += x * x;
  }
  return Math.sqrt(sum / Math.max(1, floats.length));
}

export class Sound {
  /** `onChange()`: the state or the numbers changed (for the page's controls). */
  constructor({ onChange = () => {} } = {}) {
    this.onChange = onChange;
    this.context = null;
    this.gain = null;
    this.decoder = null;
    this.decoding = [];
    this.volume = 1;
    this.muted = false;
    this.codec = null;
    this.syncLog = [];
    /** Stream seconds per second heard: 1 but for a replay played slower or faster. */
    this.rate = 1;
    this.reset();
  }

  /** Forgets the timeline (a stream started over), keeping the rate. */
  reset() {
    this.offset = null;
    /** The playout delay a run starts with (restart), else the jitter's, seconds. */
    this.startDelay = null;
    this.transits = [];
    this.pieces = [];
    this.scheduledEnd = 0;
    this.decoder?.close?.();
    this.decoder = null;
    this.decoding = [];
    this.numbers = { late: 0, lowered: 0 };
  }

  /**
   * A new run of the voice (a new connection; a replay sought, looped, paused or played at
   * another speed): the timeline forgotten, and `rate` stream seconds heard per second
   * from now on.
   */
  restart(rate) {
    // The playout delay the last run needed is where the next starts: a replay's runs
    // come over the same connection, with the same jitter.
    const delay = this.offset === null ? null : this.offset - Math.min(...this.transits);
    this.reset();
    this.startDelay = delay;
    this.rate = rate > 0 ? rate : 1;
  }

  /** True once a click started the context and it runs. */
  get playing() {
    return this.context !== null && this.context.state === "running";
  }

  /** The user's click: starts (or resumes) the context. Returns a promise. */
  async enable() {
    if (!this.context) {
      this.context = new AudioContext({ latencyHint: "interactive" });
      this.gain = this.context.createGain();
      this.gain.connect(this.context.destination);
      this.applyVolume();
      this.context.onstatechange = () => this.onChange();
    }
    await this.context.resume();
    this.onChange();
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

  /** An audio chunk as decodeAudio gives it, just arrived. */
  push(chunk) {
    this.codec = chunk.codec;
    if (!this.playing) {
      return; // nothing to play it on yet; the timeline starts with the first chunk after the click
    }
    if (chunk.codec === "pcm") {
      const floats = new Float32Array(chunk.samples.length);
      for (let i = 0; i < floats.length; i++) {
        floats[i] = chunk.samples[i] / 32768;
      }
      this.schedule(chunk.t, chunk.sampleRate, floats, chunk.serverReceiveUs);
    } else {
      this.decodeOpus(chunk);
    }
  }

  decodeOpus(chunk) {
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
      this.schedule(chunk.t, rate, floats, chunk.serverReceiveUs);
    }
  }

  /**
   * Plays `floats` (mono, at `rate` Hz) for stream time `t` after the playout delay: on
   * the context's clock at `u + offset`, `u` the stream time in seconds heard (t / the
   * sound's rate).
   */
  schedule(t, rate, floats, serverReceiveUs) {
    const context = this.context;
    const now = context.currentTime;
    const u = t / this.rate;
    this.transits.push(now - u);
    if (this.transits.length > TRANSIT_WINDOW) {
      this.transits.shift();
    }
    const fastest = Math.min(...this.transits);
    const target = fastest + this.targetDelay();
    if (this.offset === null) {
      this.offset = Math.max(target, fastest + (this.startDelay ?? 0));
    }
    let at = u + this.offset;
    if (at < now + SCHEDULE_AHEAD_S) {
      // Too late to play: a longer delay from now on (the gap is heard once).
      this.numbers.late += 1;
      this.offset = Math.max(target, now + SCHEDULE_AHEAD_S + DELAY_MARGIN_S - u);
      at = u + this.offset;
    } else if (this.offset > target + LOWER_BY_OVER_S && rms(floats) < QUIET_RMS) {
      // More delay than the jitter needs: shorten it in a pause, dropping this quiet chunk's overlap.
      this.numbers.lowered += 1;
      this.offset = Math.max(target, now + SCHEDULE_AHEAD_S - u);
      at = u + this.offset;
    }
    // Never over audio already scheduled: skip what would overlap.
    let skip = 0;
    if (at < this.scheduledEnd - EPSILON_S) {
      skip = Math.min(floats.length, Math.ceil((this.scheduledEnd - at) * rate));
    }
    if (skip < floats.length) {
      const buffer = context.createBuffer(1, floats.length - skip, rate);
      buffer.copyToChannel(skip > 0 ? floats.subarray(skip) : floats, 0);
      const source = context.createBufferSource();
      source.buffer = buffer;
      source.connect(this.gain);
      const start = at + skip / rate;
      source.start(start);
      this.scheduledEnd = start + (floats.length - skip) / rate;
      const pieceT = t + (skip / rate) * this.rate;
      this.pieces.push({ start, end: this.scheduledEnd, t: pieceT, rate: this.rate, serverReceiveUs });
      if (this.pieces.length > KEEP_PIECES) {
        this.pieces.shift();
      }
    }
  }

  /** Jitter of the arrivals (95th percentile of transit above the fastest) plus the margin. */
  targetDelay() {
    if (this.transits.length === 0) {
      return MIN_DELAY_S;
    }
    const jitter = quantile(this.transits, 0.95) - Math.min(...this.transits);
    return Math.min(MAX_DELAY_S, Math.max(MIN_DELAY_S, jitter + DELAY_MARGIN_S));
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
    if (!this.playing || this.offset === null || this.transits.length === 0) {
      return null;
    }
    const context = this.context;
    const output = context.outputLatency || context.baseLatency || 0;
    return {
      codec: this.codec,
      delayMs: (this.offset - Math.min(...this.transits)) * 1000,
      targetMs: this.targetDelay() * 1000,
      outputMs: output * 1000,
      earMs: this.earLatencyMs(perfNow),
      late: this.numbers.late,
      lowered: this.numbers.lowered,
    };
  }
}
