// draw-scale.js: how many pixels the heads are drawn with while their voice plays. A frame
// shows when its sound is heard only to within half the time between the page's chances to
// draw (head-group.js): on a machine whose draws are slow (software WebGL, a weak phone)
// chances come 50 ms or more apart and the face is that much late or early. Most of such a
// draw is filling pixels, so while the voice plays the group draws fewer of them, a step of
// SCALES at a time down to half the device's pixels a side, until the chances come within
// SLOW_MS again; it raises them back when the chances come much faster, undoes a cut that
// did not make the draws faster (a page slowed by something else keeps its sharpness), and
// waits longer each time a raise has to be taken back. Without a voice the heads are always
// drawn at full resolution.

import { quantile } from "./quantile.js";

/** Chances to draw judged together. */
export const WINDOW = 30;
/** The fractions of the device's pixels a side the heads may be drawn with (each about 70 % of the pixels of the one before). */
export const SCALES = [1, 0.84, 0.71, 0.6, 0.5];
/**
 * Chances further apart than this at the 90th percentile are too slow, ms: a frame shows
 * within half the interval of its sound, and the goal is within 20 ms (two frames of a 60 Hz
 * display at most, a 30 Hz display's every frame).
 */
export const SLOW_MS = 40;
/** Chances this close at the 90th percentile leave room to draw more, ms (a 60 Hz display's every frame, with its jitter). */
export const FAST_MS = 25;
/** Fast windows in a row before a raise. */
export const FAST_WINDOWS = 3;
/** A cut that made the mean interval no shorter than this fraction of before did not help. */
export const HELPED = 0.95;
/** Windows without a cut after one that did not help. */
export const HOLD_WINDOWS = 20;
/** Windows without a raise after the first raise taken back; doubled by each one after. */
export const FIRST_RAISE_HOLD = 20;
/** The longest wait for a raise, windows. */
const MOST_RAISE_HOLD = 320;

export class DrawScale {
  constructor() {
    /** Where in SCALES the heads are drawn. */
    this.step = 0;
    this.window = [];
    this.fastWindows = 0;
    this.windows = 0;
    /** No cut until after this window (a cut undone). */
    this.holdUntil = 0;
    /** No raise until after this window, and the wait after the next raise taken back. */
    this.raiseHoldUntil = 0;
    this.raiseHold = FIRST_RAISE_HOLD;
    /** The cut being judged: the mean interval before it, ms. */
    this.cutFromMeanMs = null;
    /** Whether a raise is being judged. */
    this.raised = false;
  }

  /** The fraction of the device's pixels a side the heads are drawn with (0.5..1). */
  get scale() {
    return SCALES[this.step];
  }

  /**
   * One chance to draw came `intervalMs` after the last; `voicePlaying` says whether the
   * heads are drawn by their voice's clock. True when the scale changed.
   */
  chance(intervalMs, voicePlaying) {
    if (!voicePlaying) {
      this.window = [];
      this.cutFromMeanMs = null;
      this.raised = false;
      this.fastWindows = 0;
      this.raiseHold = FIRST_RAISE_HOLD;
      const changed = this.step !== 0;
      this.step = 0;
      return changed;
    }
    this.window.push(intervalMs);
    if (this.window.length < WINDOW) {
      return false;
    }
    const before = this.step;
    this.judge(this.window);
    this.window = [];
    return this.step !== before;
  }

  /** Judges a full window of intervals, ms. */
  judge(intervals) {
    this.windows += 1;
    const p90 = quantile(intervals, 0.9);
    const meanMs = intervals.reduce((sum, value) => sum + value, 0) / intervals.length;
    const slow = p90 > SLOW_MS;
    if (this.cutFromMeanMs !== null) {
      const meanBefore = this.cutFromMeanMs;
      this.cutFromMeanMs = null;
      if (meanMs > HELPED * meanBefore) {
        // Fewer pixels did not make the draws faster: they are slow for another reason.
        this.step -= 1;
        this.holdUntil = this.windows + HOLD_WINDOWS;
        return;
      }
    }
    if (this.raised) {
      this.raised = false;
      if (slow) {
        // The raise was too much: back, and wait longer each time before the next.
        this.step += 1;
        this.raiseHoldUntil = this.windows + this.raiseHold;
        this.raiseHold = Math.min(MOST_RAISE_HOLD, this.raiseHold * 2);
        this.fastWindows = 0;
        return;
      }
    }
    if (slow) {
      this.fastWindows = 0;
      if (this.step < SCALES.length - 1 && this.windows > this.holdUntil) {
        this.cutFromMeanMs = meanMs;
        this.step += 1;
      }
    } else if (p90 <= FAST_MS) {
      this.fastWindows += 1;
      if (this.fastWindows >= FAST_WINDOWS && this.step > 0 && this.windows > this.raiseHoldUntil) {
        this.fastWindows = 0;
        this.raised = true;
        this.step -= 1;
      }
    } else {
      this.fastWindows = 0;
    }
  }
}
