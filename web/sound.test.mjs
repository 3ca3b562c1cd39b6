// sound.test.mjs: checks the sound's wait for the face (sound.js tuneFace), with a
// stand-in for the audio thread's port: frames drawn late for their sound lengthen the
// playout delay by half their 95th percentile above 20 ms, frames in time take it back,
// never below nothing, and too few frames change nothing. Run `node web/sound.test.mjs`;
// the exit status is the verdict. Not served: the page never loads this file.

import { Sound } from "./sound.js";

const failures = [];

function near(actual, expected, path) {
  if (!(Math.abs(actual - expected) <= 1e-9)) {
    failures.push(`${path}: ${actual} != ${expected}`);
  }
}

function same(actual, expected, path) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

const told = [];
const sound = new Sound();
sound.node = { port: { postMessage: (message) => told.push(message.faceExtraS) } };

function drawn(lateMs) {
  for (const ms of lateMs) {
    sound.faceShown(ms);
  }
  sound.tuneFace();
}

// Four frames are too few to judge by.
drawn([100, 100, 100, 100]);
same(told, [], "four frames change nothing");
// With a fifth, all 100 ms late: the delay grows by half of 100 - 20 ms.
drawn([100]);
same(told.length, 1, "told once");
near(told[0], 0.04, "half the lateness above the aim");
// Ten frames 50 ms early: it gives back half of 70 ms, down to 5 ms.
drawn(Array(10).fill(-50));
near(told[1], 0.005, "given back");
// And never below nothing.
drawn(Array(10).fill(-50));
same(told[2], 0, "never below nothing");
// Frames at the aim: no change, nothing told.
drawn(Array(10).fill(20));
same(told.length, 3, "at the aim, nothing told");

if (failures.length > 0) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log("sound.js: every case holds");
