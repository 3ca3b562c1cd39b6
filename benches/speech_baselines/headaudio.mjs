// headaudio.mjs: @met4citizen/headaudio 0.1.0's classifier on the held-out corpus, for
// benches/speech_visemes.py. Its audio processor (the code its AudioWorklet runs) is fed
// each file in 128-sample blocks, as a worklet is, with its shipped model
// (dist/model-en-mixed.bin) and its default parameters; every viseme it decides is written
// with the centre of the audio it decided on. Wav paths on stdin, one per line; one JSON
// line per file on stdout: {"file", "decisions": [[centre_s, viseme], ...], "cpu_s"},
// visemes named as facewire names them ("sil" when it is not speaking).
//
//     node benches/speech_baselines/headaudio.mjs < wavs.txt

import { readFileSync } from "node:fs";
import { createInterface } from "node:readline";
import { fileURLToPath } from "node:url";
import { Processor } from "@met4citizen/headaudio/modules/processor.mjs";
import { Training } from "@met4citizen/headaudio/modules/training.mjs";
import { readWav } from "./wav.mjs";

/** HeadAudio's viseme ids (its README, appendix A) as facewire names them. */
const NAMES = ["aa", "E", "ih", "oh", "ou", "PP", "SS", "TH", "DD", "FF", "kk", "nn", "RR", "CH", "sil"];
/** An AudioWorklet's render quantum. */
const BLOCK = 128;

const modelPath = fileURLToPath(import.meta.resolve("@met4citizen/headaudio/dist/model-en-mixed.bin"));
// Its loader fetches a URL; the model is read from the installed package instead.
globalThis.fetch = async (path) => new Response(readFileSync(path));
const { model } = await new Training().loadModel(modelPath);

function track(path) {
  const { samples, rate } = readWav(path);
  const decisions = [];
  const port = {
    postMessage(message) {
      if (message.event === "viseme") {
        decisions.push([message.t, NAMES[message.viseme]]);
      } else if (message.event === "ended") {
        // Decided at the end of the audio it read: silence from that audio's centre.
        decisions.push([message.t - processor.vectorDuration / 2, "sil"]);
      }
    },
  };
  const processor = new Processor({ sampleRate: rate }, { port });
  processor._onmessage({ data: { event: "model", model } });
  const started = process.cpuUsage();
  for (let at = 0; at < samples.length; at += BLOCK) {
    processor.process(samples.subarray(at, Math.min(samples.length, at + BLOCK)));
  }
  const used = process.cpuUsage(started);
  return { file: path, decisions, cpu_s: (used.user + used.system) / 1e6 };
}

for await (const line of createInterface({ input: process.stdin })) {
  if (line.trim()) {
    console.log(JSON.stringify(track(line.trim())));
  }
}
