// playout.js: the voice's jitter buffer, on the audio context's sample clock. Decoded
// chunks of the voice (mono floats, `t` the stream time of their first sample) are written
// into a ring of samples at the context frame where they are to be heard, `u + offset`
// seconds, `u` the stream time in seconds heard (t / the run's rate: a replay played slower
// or faster sends its voice stretched at the same pitch). The audio thread (playout-worklet.js)
// reads the ring as it plays. It runs there, not on the page's main thread, so a chunk's
// arrival is timed when it arrives, however long the page takes to draw.
//
// The offset follows the jitter of the chunks' arrival: the spread of their transit times
// (95th percentile above the fastest) plus a margin, raised at once when a chunk comes too
// late to play, and lowered only in a quiet chunk (a pause between words), so speech is
// never cut. The face may need more: on a page slow to draw, frames come to the screen
// after their sound, and the page asks for that much more delay (setFaceExtra), added in
// a quiet chunk, so the voice waits for the face rather than the face lagging the voice. A chunk at another sample rate than the context's is interpolated linearly
// (from the previous chunk's last sample when it follows on, so the seam is smooth; the
// voice is then heard 1/rate later, under 63 microseconds).

import { quantile } from "./quantile.js";

/** The playout delay never goes below this or above that, seconds. */
export const MIN_DELAY_S = 0.06;
export const MAX_DELAY_S = 1.0;
/** Above the arrival jitter: room for a late chunk, seconds. */
export const DELAY_MARGIN_S = 0.03;
/** A chunk must be placed at least this far ahead of the next frame to play, seconds. */
const SCHEDULE_AHEAD_S = 0.005;
/** Transit times kept for the jitter estimate: 10 s of 20 ms chunks. */
const TRANSIT_WINDOW = 500;
/** The delay is lowered when it exceeds its target by this much, in a quiet chunk, seconds. */
const LOWER_BY_OVER_S = 0.02;
/** A chunk whose RMS is below this (of full scale) is quiet. */
const QUIET_RMS = 0.01;
/** Seconds of samples the ring holds: the longest delay, a chunk, and room to spare. */
const RING_S = 4;
/** A chunk this close to where the last one ended (frames) follows on from it. */
const FOLLOWS_ON_FRAMES = 2;

function rms(floats) {
  let sum = 0;
  for (const x of floats) {
    sum += x * x;
  }
  return Math.sqrt(sum / Math.max(1, floats.length));
}

export class JitterBuffer {
  /** `sampleRate`: the context's, Hz. */
  constructor(sampleRate) {
    this.sampleRate = sampleRate;
    this.ring = new Float32Array(Math.ceil(RING_S * sampleRate));
    /** The first context frame not yet played (render moves it on). */
    this.playedEnd = 0;
    /** Stream seconds per second heard: 1 but for a replay played slower or faster. */
    this.rate = 1;
    this.startDelay = null;
    this.codec = null;
    this.late = 0;
    this.lowered = 0;
    this.raised = 0;
    /** More delay than the jitter's that the page's frames need to be drawn when heard, seconds. */
    this.faceExtra = 0;
    this.dropped = 0;
    this.reset();
  }

  /** Forgets the timeline (a stream started over), keeping the rate. */
  reset() {
    this.offset = null;
    this.transits = [];
    /** The context frame where the audio written so far ends. */
    this.scheduledEnd = 0;
    /** The last sample written, and its chunk's rate: the next chunk's seam. */
    this.lastSample = 0;
    this.lastRate = 0;
  }

  /**
   * A new run of the voice (a new connection; a replay sought, looped, paused or played at
   * another speed): the timeline forgotten, and `rate` stream seconds heard per second from
   * now on. The playout delay the last run needed is where the next starts: a replay's runs
   * come over the same connection, with the same jitter.
   */
  restart(rate) {
    const delay = this.offset === null ? null : this.offset - Math.min(...this.transits);
    this.reset();
    this.startDelay = delay;
    this.rate = rate > 0 ? rate : 1;
  }

  /** More delay than the jitter's that the page's frames need, seconds (at least 0). */
  setFaceExtra(seconds) {
    this.faceExtra = Number.isFinite(seconds) ? Math.max(0, seconds) : 0;
  }

  /**
   * The delay wanted, seconds: the jitter of the arrivals (95th percentile of transit
   * above the fastest) plus the margin, plus what the face needs beyond that.
   */
  targetDelay() {
    const jitter = this.transits.length === 0 ? 0 : quantile(this.transits, 0.95) - Math.min(...this.transits);
    return Math.min(MAX_DELAY_S, Math.max(MIN_DELAY_S, jitter + DELAY_MARGIN_S) + this.faceExtra);
  }

  /**
   * A decoded chunk `{t, sampleRate, floats, serverReceiveUs, codec}` arriving when the
   * context is at frame `frame`: written where it is to be heard. Returns the piece heard
   * `{start, end, t, rate, serverReceiveUs}` (start and end in context seconds), or null
   * when nothing of it is to be played (all of it overlaps audio already placed, or it
   * lies beyond the ring).
   */
  push(chunk, frame) {
    const R = this.sampleRate;
    const nowFrame = Math.max(frame, this.playedEnd);
    const now = nowFrame / R;
    this.codec = chunk.codec;
    const u = chunk.t / this.rate;
    this.transits.push(now - u);
    if (this.transits.length > TRANSIT_WINDOW) {
      this.transits.shift();
    }
    const fastest = Math.min(...this.transits);
    const target = fastest + this.targetDelay();
    if (this.offset === null) {
      this.offset = Math.max(target, fastest + (this.startDelay ?? 0));
    }
    if (u + this.offset < now + SCHEDULE_AHEAD_S) {
      // Too late to play: a longer delay from now on (the gap is heard once).
      this.late += 1;
      this.offset = Math.max(target, now + SCHEDULE_AHEAD_S + DELAY_MARGIN_S - u);
    } else if (Math.abs(this.offset - target) > LOWER_BY_OVER_S && rms(chunk.floats) < QUIET_RMS) {
      if (this.offset > target) {
        // More delay than needed: shorten it in a pause, dropping this quiet chunk's overlap.
        this.lowered += 1;
        this.offset = Math.max(target, now + SCHEDULE_AHEAD_S - u);
      } else {
        // Less than the face needs: lengthen it in a pause, which lasts that much longer.
        this.raised += 1;
        this.offset = target;
      }
    }
    const length = Math.round((chunk.floats.length * R) / chunk.sampleRate);
    let start = Math.round((u + this.offset) * R);
    const followsOn = Math.abs(start - this.scheduledEnd) <= FOLLOWS_ON_FRAMES;
    if (followsOn) {
      start = this.scheduledEnd;
    }
    // Never over audio already placed: skip what would overlap.
    const skip = Math.max(0, this.scheduledEnd - start);
    if (skip >= length) {
      return null;
    }
    if (start + length > nowFrame + this.ring.length) {
      this.dropped += 1; // further ahead than the ring reaches
      return null;
    }
    const seam = followsOn && this.lastRate === chunk.sampleRate ? this.lastSample : chunk.floats[0];
    this.write(chunk.floats, chunk.sampleRate, start, skip, length, seam);
    this.scheduledEnd = start + length;
    this.lastSample = chunk.floats[chunk.floats.length - 1] ?? 0;
    this.lastRate = chunk.sampleRate;
    return {
      start: (start + skip) / R,
      end: this.scheduledEnd / R,
      t: chunk.t + (skip / R) * this.rate,
      rate: this.rate,
      serverReceiveUs: chunk.serverReceiveUs,
    };
  }

  /**
   * Writes frames `skip..length` of `floats` (at `rate` Hz, `length` frames at the
   * context's rate) into the ring from context frame `start`; `seam` is the sample before
   * the first.
   */
  write(floats, rate, start, skip, length, seam) {
    const ring = this.ring;
    const n = ring.length;
    if (rate === this.sampleRate) {
      for (let j = skip; j < length; j++) {
        ring[(start + j) % n] = floats[j];
      }
      return;
    }
    // Output frame j is input position j * rate / R, less one input sample so that only
    // this chunk and the seam are needed.
    const step = rate / this.sampleRate;
    for (let j = skip; j < length; j++) {
      const x = j * step - 1;
      const i = Math.floor(x);
      const a = i < 0 ? seam : floats[i];
      const b = floats[Math.min(i + 1, floats.length - 1)];
      ring[(start + j) % n] = a + (b - a) * (x - i);
    }
  }

  /** Plays context frames `frame..frame + out.length` into `out`, clearing them in the ring. */
  render(out, frame) {
    const ring = this.ring;
    const n = ring.length;
    for (let k = 0; k < out.length; k++) {
      const i = (frame + k) % n;
      out[k] = ring[i];
      ring[i] = 0;
    }
    this.playedEnd = frame + out.length;
  }

  /** The numbers the page shows: codec, delay and its target (s), chunks late, lowered, raised, dropped; the face's extra (s); the rate. */
  numbers() {
    if (this.offset === null || this.transits.length === 0) {
      return null;
    }
    return {
      codec: this.codec,
      delayS: this.offset - Math.min(...this.transits),
      targetS: this.targetDelay(),
      late: this.late,
      lowered: this.lowered,
      raised: this.raised,
      dropped: this.dropped,
      faceExtraS: this.faceExtra,
      rate: this.rate,
    };
  }
}
