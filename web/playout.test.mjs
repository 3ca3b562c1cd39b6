// playout.test.mjs: checks playout.js, the voice's jitter buffer, by hand-computed cases
// at 48 kHz: where a chunk is placed after the playout delay, a chunk that follows on,
// one too late (the delay raised), a quiet chunk that lowers a delay the jitter no longer
// needs, one raising it to what the face needs, a 16 kHz chunk interpolated with a smooth
// seam, a replay's rate, what lies beyond the ring, and that played samples are cleared. Run `node web/playout.test.mjs`; the exit
// status is the verdict. Not served: the page never loads this file.

import { JitterBuffer, MIN_DELAY_S } from "./playout.js";

const R = 48_000;
const failures = [];

function near(actual, expected, path, tolerance = 1e-9) {
  if (!(Math.abs(actual - expected) <= tolerance)) {
    failures.push(`${path}: ${actual} != ${expected}`);
  }
}

function same(actual, expected, path) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

function chunk(t, samples, value = 0.5, sampleRate = R) {
  const floats = typeof samples === "number" ? new Float32Array(samples).fill(value) : Float32Array.from(samples);
  return { t, sampleRate, floats, serverReceiveUs: Math.round(t * 1e6), codec: "pcm" };
}

/** Plays frames up to `frame` (exclusive) from the buffer's next one, in blocks of 128 at most; their samples. */
function playUntil(buffer, until) {
  const frame = Math.round(until);
  const played = [];
  while (buffer.playedEnd < frame) {
    const block = new Float32Array(Math.min(128, frame - buffer.playedEnd));
    buffer.render(block, buffer.playedEnd);
    played.push(...block);
  }
  return played;
}

// The first chunk: transit 10 ms, no jitter yet, so the delay is the floor (60 ms) and
// the chunk, t = 0.99 s arriving at 1 s, plays from 0.99 + 0.01 + 0.06 = 1.06 s.
{
  const buffer = new JitterBuffer(R);
  buffer.playedEnd = R;
  const piece = buffer.push(chunk(0.99, 960), R);
  near(piece.start, 1.06, "first piece start");
  near(piece.end, 1.08, "first piece end");
  near(piece.t, 0.99, "first piece t");
  near(buffer.numbers().delayS, MIN_DELAY_S, "first delay");
  same(buffer.numbers().late, 0, "first late");
  // The next 20 ms arriving with the same transit follows on exactly.
  const next = buffer.push(chunk(1.01, 960, 0.25), R + 960);
  near(next.start, 1.08, "next piece follows on");
  // Played: silence until 1.06 s (frame 50880), then 0.5 for 960 frames, then 0.25.
  const played = playUntil(buffer, 1.1 * R);
  same(played[50880 - R - 1], 0, "silence before the piece");
  same(played[50880 - R], 0.5, "the piece's first sample");
  same(played[50880 - R + 959], 0.5, "the piece's last sample");
  same(played[50880 - R + 960], 0.25, "the next piece's first sample");
  // Played samples are cleared: a whole ring later they are silence.
  const later = new Float32Array(1);
  buffer.render(later, 50880 + buffer.ring.length);
  same(later[0], 0, "played samples are cleared");
}

// A chunk too late to play: t = 1.03 s arriving at 1.2 s (transit 170 ms against 10).
// The transits are [0.01, 0.01, 0.17]: the 95th percentile is 0.17, so the jitter is 0.16
// and the target delay 0.19; at the old offset (0.07) it would play at 1.10 s, before
// now, so the offset becomes 1.2 + 0.005 + 0.03 - 1.03 = 0.205 (more than the target's 0.2).
{
  const buffer = new JitterBuffer(R);
  buffer.playedEnd = R;
  buffer.push(chunk(0.99, 960), R);
  buffer.push(chunk(1.01, 960), R + 960);
  playUntil(buffer, 1.2 * R);
  const piece = buffer.push(chunk(1.03, 960), 1.2 * R);
  same(buffer.numbers().late, 1, "one late");
  near(piece.start, 1.235, "late piece start", 1 / R);
  near(buffer.numbers().targetS, 0.19, "target after the late chunk", 1e-9);
}

// A delay the jitter no longer needs is lowered in a quiet chunk only. 100 chunks of 20 ms
// with a 10 ms transit, then a 300 ms stall: the chunk of t = 2 s arrives at 2.31 s (the
// offset becomes 2.31 + 0.035 - 2 = 0.345, the delay 0.335 above the fastest transit) and
// the 15 sent during the stall arrive with it; then 385 more on time. 16 late ones in the
// last 500 leave the 95th percentile at 10 ms, the target 60 ms above the fastest. Loud
// chunks keep the long delay; the first quiet one lowers it to the target.
{
  const buffer = new JitterBuffer(R);
  const at = (t, transit) => Math.round((t + transit) * R);
  for (let i = 0; i < 100; i++) {
    const t = i * 0.02;
    playUntil(buffer, at(t, 0.01));
    buffer.push(chunk(t, 960), at(t, 0.01));
  }
  playUntil(buffer, at(2.0, 0.31));
  buffer.push(chunk(2.0, 960), at(2.0, 0.31));
  same(buffer.numbers().late, 1, "the late chunk");
  near(buffer.numbers().delayS, 0.335, "delay after the late chunk", 1e-6);
  for (let i = 1; i <= 400; i++) {
    const t = 2.0 + i * 0.02;
    playUntil(buffer, at(t, 0.01));
    buffer.push(chunk(t, 960), at(t, 0.01));
  }
  same(buffer.numbers().lowered, 0, "loud chunks never lower the delay");
  near(buffer.numbers().delayS, 0.335, "the delay kept through speech", 1e-6);
  const t = 10.02;
  playUntil(buffer, at(t, 0.01));
  buffer.push(chunk(t, 960, 0), at(t, 0.01));
  same(buffer.numbers().lowered, 1, "a quiet chunk lowers it");
  near(buffer.numbers().delayS, MIN_DELAY_S, "to the target", 1e-6);
}

// The face needs 90 ms more than the jitter's 60. A loud chunk keeps the delay (speech is
// never cut); the next quiet one raises it: played from t + 0.01 + 0.15.
{
  const buffer = new JitterBuffer(R);
  buffer.playedEnd = R;
  buffer.push(chunk(0.99, 960), R);
  buffer.setFaceExtra(0.09);
  near(buffer.numbers().targetS, 0.15, "the target is the jitter's and the face's extra");
  buffer.push(chunk(1.01, 960), R + 960);
  same(buffer.numbers().raised, 0, "a loud chunk keeps the delay");
  near(buffer.numbers().delayS, MIN_DELAY_S, "the delay kept through speech");
  const piece = buffer.push(chunk(1.03, 960, 0), R + 1920);
  same(buffer.numbers().raised, 1, "a quiet chunk raises it");
  near(buffer.numbers().delayS, 0.15, "by the face's extra");
  near(piece.start, 1.19, "the quiet chunk plays 150 ms after its transit", 1 / R);
  buffer.setFaceExtra(NaN);
  near(buffer.numbers().targetS, MIN_DELAY_S, "an extra that is not a number is none");
}

// A 16 kHz chunk is interpolated to 48 kHz one input sample late: output frame j is input
// position j / 3 - 1, the first from the chunk's own first sample. A chunk that follows on
// starts from the last one's last sample: no step at the seam.
{
  const buffer = new JitterBuffer(R);
  buffer.playedEnd = R;
  const ramp = Array.from({ length: 320 }, (_, i) => i / 1000);
  const piece = buffer.push(chunk(0.99, ramp, 0, 16_000), R);
  near(piece.end - piece.start, 0.02, "320 samples at 16 kHz last 20 ms");
  const start = Math.round(piece.start * R);
  const next = buffer.push(chunk(1.01, ramp.map((x) => x + 0.32), 0, 16_000), R + 960);
  near(next.start, piece.end, "the 16 kHz chunk follows on");
  const played = playUntil(buffer, start + 1920 + 128);
  const out = (j) => played[start - R + j];
  near(out(0), 0, "frame 0: the chunk's first sample", 1e-7);
  near(out(3), 0, "frame 3: input 0", 1e-7);
  near(out(4), 1 / 3000, "frame 4: input 1/3", 1e-7);
  near(out(959), 959 / 3000 - 0.001, "frame 959: input 318 2/3", 1e-7);
  near(out(960), 0.319, "the seam: the last chunk's last sample", 1e-7);
  near(out(961), 0.319 + 0.001 / 3, "a third of the way to the next chunk's first", 1e-7);
}

// A replay at half speed: u = t / 0.5, and the piece says its rate.
{
  const buffer = new JitterBuffer(R);
  buffer.restart(0.5);
  buffer.playedEnd = R;
  const piece = buffer.push(chunk(0.49, 960), R);
  near(piece.start, 1.06, "half-speed piece start (u = 0.98, transit 0.02)", 1e-9);
  same(piece.rate, 0.5, "half-speed piece rate");
  same(buffer.numbers().rate, 0.5, "half-speed numbers");
}

// What lies beyond the ring is dropped, not written over audio still to play.
{
  const buffer = new JitterBuffer(R);
  buffer.playedEnd = R;
  buffer.push(chunk(0.99, 960), R);
  const far = buffer.push(chunk(10, 960), R);
  same(far, null, "a chunk beyond the ring");
  same(buffer.numbers().dropped, 1, "counted as dropped");
}

if (failures.length > 0) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log("playout.js: every case holds");
