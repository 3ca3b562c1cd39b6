// wlipsync.mjs: wlipsync 1.3.1 (uLipSync's MFCC matching, compiled to WebAssembly) on the
// held-out corpus, for benches/speech_visemes.py. The package ships no profile (its authors
// make theirs with uLipSync's calibration in Unity), so one is calibrated here the way
// uLipSync calibrates, from speech: the package's own MFCC of frames of clean training
// speech (never held-out speech), 16 per viseme, uLipSync's default settings (16 kHz, 1024
// samples, 30 mel channels, L2 norm). `--visemes vowels` calibrates the five vowels people
// usually give it (aa E ih oh ou); `all` every one of the 15. Each file is then fed in
// 128-sample blocks with a match after each (wlipsync's finest block size); a match whose
// volume is under the node's closed-mouth volume (log10 RMS -2.5) shows silence.
//
//     node wlipsync.mjs calibrate TRAIN_DIR PROFILE.json --visemes all|vowels
//     node wlipsync.mjs run PROFILE.json < wavs.txt   (one JSON line per file, as headaudio.mjs)

import { readFileSync, writeFileSync } from "node:fs";
import { createInterface } from "node:readline";
import { readWav } from "./wav.mjs";

// The package exports no path to its WebAssembly: read from where `npm ci` put it.
const WASM = new WebAssembly.Module(readFileSync(new URL("./node_modules/wlipsync/dist/wlipsync.wasm", import.meta.url)));
/** uLipSync's profile defaults. */
const SETTINGS = { targetSampleRate: 16000, sampleCount: 1024, melFilterBankChannels: 30, compareMethod: 1, useStandardization: false };
const MFCC_NUM = 12;
const DATA_COUNT = 16;
/** The node's volume (log10 RMS) at which the mouth is closed (WLipSyncAudioNode.minVolume). */
const MIN_VOLUME = -2.5;
const BLOCK = 128;
const VOWELS = ["aa", "E", "ih", "oh", "ou"];
/** A calibration frame's window centre is at least this far inside its segment, s. */
const INSIDE_S = 0.02;

/** The package's matcher for `profile` at `rate`: `step(block)` -> {index, volume, mfcc}. */
function matcher(profile, rate) {
  const memory = new WebAssembly.Memory({ initial: 4 });
  const wasm = new WebAssembly.Instance(WASM, { env: { memory } }).exports;
  const count = profile.mfccs.length;
  const raw = wasm.load_profile(
    profile.targetSampleRate, profile.sampleCount, profile.melFilterBankChannels,
    profile.compareMethod, count, profile.mfccDataCount, profile.useStandardization ? 1 : 0,
  );
  const data = new Float32Array(memory.buffer, raw, count * profile.mfccDataCount * MFCC_NUM);
  data.set(profile.mfccs.flatMap((m) => m.mfccCalibrationDataList.flatMap((d) => d.array)));
  wasm.precompute_profile();
  wasm.set_input(rate);
  const input = new Float32Array(memory.buffer, wasm.get_input_buffer(), wasm.get_input_buffer_size());
  const volume = new DataView(memory.buffer, wasm.get_volume_ptr(), 4);
  const mfcc = new Float32Array(memory.buffer, wasm.mfccOut.value, MFCC_NUM);
  let at = 0;
  return (block) => {
    for (const sample of block) {
      input[at] = sample;
      at = (at + 1) % input.length;
    }
    const index = wasm.execute(at);
    return { index, volume: volume.getFloat32(0, true), mfcc: Array.from(mfcc) };
  };
}

/** Each match over a file: [window centre s, result], every BLOCK samples. */
function matches(profile, samples, rate) {
  const step = matcher(profile, rate);
  const windowS = profile.sampleCount / profile.targetSampleRate;
  const out = [];
  for (let at = 0; at + BLOCK <= samples.length; at += BLOCK) {
    out.push([(at + BLOCK) / rate - windowS / 2, step(samples.subarray(at, at + BLOCK))]);
  }
  return out;
}

function calibrate(trainDir, outPath, which) {
  const names = which === "vowels" ? VOWELS : ["sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"];
  const lines = readFileSync(`${trainDir}/index.tsv`, "utf8").trim().split("\n");
  const header = lines[0].split("\t");
  const items = lines.slice(1).map((line) => Object.fromEntries(line.split("\t").map((v, i) => [header[i], v])));
  // Clean speech only, as a calibration is recorded: no noise, room or telephone.
  const clean = items.filter((i) => i.noise === "none" && i.rt60_s === "-" && i.telephone === "no");
  // Any profile gives the package's MFCC of each window; the match itself is not used.
  const probe = { ...SETTINGS, mfccNum: MFCC_NUM, mfccDataCount: 1, mfccs: [{ name: "x", mfccCalibrationDataList: [{ array: new Array(MFCC_NUM).fill(0) }] }] };
  const found = Object.fromEntries(names.map((n) => [n, []]));
  for (const item of clean) {
    const { samples, rate } = readWav(`${trainDir}/${item.name}.wav`);
    const segments = readFileSync(`${trainDir}/${item.name}.lab`, "utf8").trim().split("\n").map((l) => {
      const [start, end, , viseme] = l.split("\t");
      return { start: Number(start), end: Number(end), viseme };
    });
    for (const [centre, { mfcc, volume }] of matches(probe, samples, rate)) {
      const segment = segments.find((s) => s.start + INSIDE_S <= centre && centre <= s.end - INSIDE_S);
      if (segment && found[segment.viseme] && (segment.viseme === "sil" || Math.log10(volume) >= MIN_VOLUME)) {
        found[segment.viseme].push(mfcc);
      }
    }
  }
  const mfccs = names.map((name) => {
    const all = found[name];
    if (all.length < DATA_COUNT) {
      throw new Error(`${name}: ${all.length} calibration frames in ${clean.length} clean items; ${DATA_COUNT} needed`);
    }
    // Spread over everything found (every voice), as a calibration spoken over time is.
    const picked = Array.from({ length: DATA_COUNT }, (_, k) => all[Math.floor(((k + 0.5) * all.length) / DATA_COUNT)]);
    return { name, mfccCalibrationDataList: picked.map((array) => ({ array })) };
  });
  writeFileSync(outPath, JSON.stringify({ ...SETTINGS, mfccNum: MFCC_NUM, mfccDataCount: DATA_COUNT, mfccs }));
  console.error(`${outPath}: ${names.length} visemes from ${clean.length} clean training items (${names.map((n) => `${n} ${found[n].length}`).join(", ")} frames)`);
}

function track(profile, path) {
  const { samples, rate } = readWav(path);
  const started = process.cpuUsage();
  const decisions = matches(profile, samples, rate).map(([centre, { index, volume }]) => [
    centre,
    Math.log10(volume) < MIN_VOLUME ? "sil" : profile.mfccs[index].name,
  ]);
  const used = process.cpuUsage(started);
  return { file: path, decisions, cpu_s: (used.user + used.system) / 1e6 };
}

const [command, ...rest] = process.argv.slice(2);
if (command === "calibrate") {
  const [trainDir, outPath, flag, which] = rest;
  if (flag !== "--visemes" || !["all", "vowels"].includes(which)) {
    throw new Error("usage: node wlipsync.mjs calibrate TRAIN_DIR PROFILE.json --visemes all|vowels");
  }
  calibrate(trainDir, outPath, which);
} else if (command === "run") {
  const profile = JSON.parse(readFileSync(rest[0], "utf8"));
  for await (const line of createInterface({ input: process.stdin })) {
    if (line.trim()) {
      console.log(JSON.stringify(track(profile, line.trim())));
    }
  }
} else {
  throw new Error("usage: node wlipsync.mjs calibrate ... | run PROFILE.json < wavs.txt");
}
