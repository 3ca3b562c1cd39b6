#!/usr/bin/env python3
"""facewire's speech-to-viseme stage against the energy-gate baseline, in one run, on a
held-out corpus: the table in docs/SPEECH.md ("Figures on held-out speech").

Runs `facewire speech FILE.wav --decisions ...` on every wav of the corpus (the server's
own causal tracker, its shipped model unless --model), and the energy gate (each 10 ms
frame's level against the loudest so far: under the gate the mouth is closed, PP;
otherwise open, aa), and scores both against the synthesizers' own phoneme timing per
voice with data/speech/scoring.py. Prints a Markdown table per measure and the real-time
factor of each (one process, one core).

    python3 data/speech/make_corpus.py /tmp/heldout --set heldout --seed 1
    cargo build --release
    python3 benches/speech_visemes.py target/release/facewire /tmp/heldout [--model M.safetensors]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "data" / "speech"))
from corpus import VISEMES, read_wav  # noqa: E402
from scoring import frame_labels, score  # noqa: E402

# The energy gate: a frame more than this many dB under the loudest frame so far is closed.
GATE_DB = 20.0
HOP, WINDOW = 160, 400


def energy_gate(samples):
    """One viseme per 10 ms frame (centred as facewire's), causally: PP or aa."""
    frames = max(0, (len(samples) - WINDOW) // HOP + 1)
    track = np.empty(frames, np.int64)
    loudest = -np.inf
    for i in range(frames):
        frame = samples[i * HOP : i * HOP + WINDOW]
        level = 10 * np.log10(np.mean(frame.astype(np.float64) ** 2) + 1e-12)
        loudest = max(loudest, level)
        track[i] = VISEMES.index("PP") if level < loudest - GATE_DB else VISEMES.index("aa")
    return track


def facewire(binary, wav, model, scratch):
    """facewire's decided viseme per 10 ms frame, and the seconds its tracker took."""
    decisions = scratch / "decisions.tsv"
    command = [binary, "speech", str(wav), "--out", str(scratch / "stream.jsonl"), "--decisions", str(decisions)]
    if model:
        command += ["--model", model]
    out = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    took_s = float(out.split(" visemes decided in ")[1].split(" s ")[0])
    rows = decisions.read_text().splitlines()[1:]
    return np.array([VISEMES.index(r.split("\t")[2]) for r in rows]), took_s


def fmt(value, kind):
    if value is None:
        return "-"
    return f"{100 * value:.0f} %" if kind == "share" else f"{value:.0f}"


MEASURES = (
    ("accuracy15", "15 visemes", "share"),
    ("accuracy5", "5 classes", "share"),
    ("PP_recall", "p/b/m found", "share"),
    ("PP_precision", "p/b/m precision", "share"),
    ("PP_onset_median_ms", "p/b/m onset, median ms", "ms"),
    ("PP_onset_p90_ms", "p/b/m onset, p90 ms", "ms"),
    ("FF_recall", "f/v found", "share"),
    ("FF_precision", "f/v precision", "share"),
    ("FF_onset_median_ms", "f/v onset, median ms", "ms"),
    ("mean_lag_ms", "mean lag ms", "ms"),
)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("binary")
    parser.add_argument("corpus")
    parser.add_argument("--model")
    args = parser.parse_args()
    corpus = Path(args.corpus)
    header = None
    items = []
    for line in (corpus / "index.tsv").read_text().splitlines():
        fields = line.split("\t")
        if header is None:
            header = fields
            continue
        items.append(dict(zip(header, fields)))
    per_voice = {}
    seconds = {"facewire": 0.0, "energy gate": 0.0}
    audio_s = 0.0
    with tempfile.TemporaryDirectory() as scratch:
        for n, item in enumerate(items):
            wav = corpus / f"{item['name']}.wav"
            samples, _rate = read_wav(str(wav))
            audio_s += len(samples) / 16000
            track, took_s = facewire(args.binary, wav, args.model, Path(scratch))
            seconds["facewire"] += took_s
            started = time.process_time()
            gate = energy_gate(samples)
            seconds["energy gate"] += time.process_time() - started
            labels = frame_labels(corpus / f"{item['name']}.lab", len(track))
            voice = per_voice.setdefault(item["voice"], {"facewire": [], "energy gate": []})
            voice["facewire"].append((labels, track))
            voice["energy gate"].append((labels, gate))
            if (n + 1) % 100 == 0:
                print(f"{n + 1} of {len(items)} files", file=sys.stderr)
    voices = sorted(per_voice)
    scores = {v: {system: score(pairs) for system, pairs in per_voice[v].items()} for v in voices}
    print(f"{len(items)} files, {audio_s / 60:.1f} min of held-out speech, {len(voices)} voices\n")
    print("| voice | system | " + " | ".join(title for _, title, _ in MEASURES) + " |")
    print("|---|---|" + "---|" * len(MEASURES))
    for v in voices:
        for system in ("facewire", "energy gate"):
            cells = " | ".join(fmt(scores[v][system][key], kind) for key, _, kind in MEASURES)
            print(f"| {v} | {system} | {cells} |")
    print()
    for system, s in seconds.items():
        print(f"{system}: {audio_s / max(s, 1e-9):.0f}x real time on one core")


if __name__ == "__main__":
    main()
