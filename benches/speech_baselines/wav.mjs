// wav.mjs: reads the held-out corpus's wav files (16-bit PCM, mono) for the baselines'
// harnesses, as float samples at full scale 1.0.

import { readFileSync } from "node:fs";

/** `{ samples: Float32Array, rate }` of a 16-bit mono RIFF wav; throws naming the file otherwise. */
export function readWav(path) {
  const bytes = readFileSync(path);
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const tag = (at) => bytes.toString("latin1", at, at + 4);
  if (tag(0) !== "RIFF" || tag(8) !== "WAVE") {
    throw new Error(`${path}: not a RIFF WAVE file`);
  }
  let at = 12;
  let rate = null;
  while (at + 8 <= bytes.length) {
    const id = tag(at);
    const size = view.getUint32(at + 4, true);
    const body = at + 8;
    if (id === "fmt ") {
      const format = view.getUint16(body, true);
      const channels = view.getUint16(body + 2, true);
      const bits = view.getUint16(body + 14, true);
      if (format !== 1 || channels !== 1 || bits !== 16) {
        throw new Error(`${path}: format ${format}, ${channels} channels, ${bits} bits; 16-bit mono PCM expected`);
      }
      rate = view.getUint32(body + 4, true);
    } else if (id === "data") {
      if (rate === null) {
        throw new Error(`${path}: data before its format`);
      }
      const count = Math.min(size, bytes.length - body) >> 1;
      const samples = new Float32Array(count);
      for (let i = 0; i < count; i++) {
        samples[i] = view.getInt16(body + 2 * i, true) / 32768;
      }
      return { samples, rate };
    }
    at = body + size + (size & 1);
  }
  throw new Error(`${path}: no data chunk`);
}
