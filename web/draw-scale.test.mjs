// draw-scale.test.mjs: checks draw-scale.js, the pixels drawn while the voice plays, on
// simulated pages at a 60 Hz display: one that keeps up (never cut), one whose draws are
// slow for the pixels they fill (cut until the chances come every two display frames, and
// no further), one slow for another reason (a cut undone, tried again only after a while),
// one that can draw more again (raised), one on a cliff (a raise taken back, tried ever
// more rarely), and a voice that stops (full resolution at once). Run `node
// web/draw-scale.test.mjs`; the exit status is the verdict. Not served: the page never
// loads this file.

import { DrawScale, FAST_WINDOWS, FIRST_RAISE_HOLD, HOLD_WINDOWS, SCALES, WINDOW } from "./draw-scale.js";

const FRAME_MS = 1000 / 60;
const failures = [];

function same(actual, expected, path) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

/** The interval of a chance whose draw took `drawMs`: the next display frame after it. */
function interval(drawMs) {
  return Math.max(1, Math.ceil(drawMs / FRAME_MS - 1e-9)) * FRAME_MS;
}

/**
 * Runs `windows` windows of chances on `scaler`; `drawMs(scale, window)` is a draw's time.
 * The step after each window.
 */
function run(scaler, windows, drawMs, voice = true) {
  const steps = [];
  for (let w = 0; w < windows; w++) {
    for (let c = 0; c < WINDOW; c++) {
      scaler.chance(interval(drawMs(scaler.scale, w)), voice);
    }
    steps.push(scaler.step);
  }
  return steps;
}

// A page that keeps up is never cut.
{
  const scaler = new DrawScale();
  same(new Set(run(scaler, 50, () => 10)), new Set([0]), "keeps up: full resolution");
  same(scaler.scale, 1, "keeps up: scale");
}

// Draws that cost 45 ms at full resolution, in proportion to the pixels filled: 50 ms
// apart (three display frames) is slow; at 0.84 a side 31.8 ms, two frames, is enough.
{
  const scaler = new DrawScale();
  const steps = run(scaler, 40, (scale) => 45 * scale * scale);
  same(steps.slice(0, 3), [1, 1, 1], "fill-bound: one cut, and it holds");
  same(new Set(steps), new Set([1]), "fill-bound: never further, never back");
  same(scaler.scale, SCALES[1], "fill-bound: scale");
}

// Draws of 45 ms whatever the pixels (the page is slow for another reason): the cut is
// undone after one window and not tried again for HOLD_WINDOWS.
{
  const scaler = new DrawScale();
  const steps = run(scaler, 1 + 1 + HOLD_WINDOWS + 2, () => 45);
  same(steps.slice(0, 2), [1, 0], "not fill-bound: cut, then undone");
  same(steps.slice(2, 2 + HOLD_WINDOWS), new Array(HOLD_WINDOWS).fill(0), "not fill-bound: no cut while held");
  same(steps.slice(2 + HOLD_WINDOWS), [1, 0], "not fill-bound: tried again after the hold, undone again");
}

// Slow enough for the smallest scale, then fast again (the load went away): cut step by
// step to the floor (each cut helps), then raised one step every FAST_WINDOWS fast windows.
{
  const scaler = new DrawScale();
  const slow = run(scaler, 8, (scale) => 150 * scale * scale);
  same(slow.slice(0, 4), [1, 2, 3, 4], "heavy: one step a window while each helps");
  same(scaler.scale, SCALES[SCALES.length - 1], "heavy: at the floor");
  const fast = run(scaler, 4 * FAST_WINDOWS, () => 5);
  same(
    fast.filter((_, i) => (i + 1) % FAST_WINDOWS === 0),
    [3, 2, 1, 0],
    "light again: a step up each FAST_WINDOWS windows",
  );
}

// A cliff: 50 ms at full resolution, 10 ms at 0.84. The raise back to full is taken back
// at once, and tried again after FIRST_RAISE_HOLD windows, then twice that, and so on.
{
  const scaler = new DrawScale();
  const windows = 200;
  const steps = run(scaler, windows, (scale) => (scale > 0.9 ? 50 : 10));
  const raises = steps.filter((step, i) => i > 0 && step < steps[i - 1]).length;
  const atFull = steps.filter((step) => step === 0).length;
  same(steps.slice(0, 1 + FAST_WINDOWS + 1), [1, 1, 1, 0, 1], "cliff: cut, three fast windows, raise taken back");
  same(raises, 4, "cliff: raises in 200 windows (after 3, 20 + 3, 40 and 80 windows)");
  same(atFull, 4, "cliff: windows at full resolution");
  same(FIRST_RAISE_HOLD, 20, "cliff: the first hold the counts above assume");
}

// The voice stops: full resolution at the next chance.
{
  const scaler = new DrawScale();
  run(scaler, 3, (scale) => 45 * scale * scale);
  same(scaler.step, 1, "voice: cut while it plays");
  same(scaler.chance(FRAME_MS, false), true, "voice stopped: the scale changed");
  same(scaler.scale, 1, "voice stopped: full resolution");
  same(scaler.chance(FRAME_MS, false), false, "voice stopped: no change after");
}

if (failures.length > 0) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log("draw-scale.js: every case holds");
