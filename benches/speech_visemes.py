#!/usr/bin/env python3
"""facewire's speech-to-viseme stage against the baselines, in one run, on a held-out
corpus: the table in docs/SPEECH.md ("Figures on held-out speech").

Runs `facewire speech FILE.wav --decisions ...` on every wav of the corpus (the server's
own causal tracker, its shipped model unless --model), the energy gate (each 10 ms
frame's level against the loudest so far: under the gate the mouth is closed, PP;
otherwise open, aa), and, unless --no-npm, the npm lip-sync libraries under node
(benches/speech_baselines/: @met4citizen/headaudio 0.1.0 with its shipped model, and
wlipsync 1.3.1 with profiles calibrated from clean training speech, all 15 visemes and
the five vowels; `npm ci` installs them there), and scores each against the
synthesizers' own phoneme timing per voice with data/speech/scoring.py. A library's
decision counts for the 10 ms frames from the centre of the audio it decided on (its
look-ahead, half its window, is printed). Prints a Markdown table per voice and system,
the real-time factor of each (one process, one core) and each one's look-ahead.

    python3 data/speech/make_corpus.py /tmp/heldout --set heldout --seed 1
    python3 data/speech/make_corpus.py /tmp/calibration --set train --items 600 --seed 11
    cargo build --release
    (cd benches/speech_baselines && npm ci)
    python3 benches/speech_visemes.py target/release/facewire /tmp/heldout --calibration /tmp/calibration [--model M.safetensors]
"""

import argparse
import json
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
from scoring import frame_centre_s, frame_labels, score  # noqa: E402

BASELINES = ROOT / "benches" / "speech_baselines"
# Each npm library's look-ahead: half the window it decides on, ms (headaudio: 512 samples
# at 16 kHz; wlipsync: uLipSync's 1024 at 16 kHz).
LOOK_AHEAD_MS = {"headaudio": 16.0, "wlipsync, 15 visemes": 32.0, "wlipsync, vowels": 32.0}

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


def npm_tracks(script_args, wavs):
    """{wav: (decisions [(centre_s, viseme index)], cpu seconds)} from a node harness of
    benches/speech_baselines/ given every wav on its stdin."""
    out = subprocess.run(
        ["node", *script_args], input="\n".join(str(w) for w in wavs), check=True, capture_output=True, text=True,
        cwd=BASELINES,
    ).stdout
    tracks = {}
    for line in out.splitlines():
        result = json.loads(line)
        decisions = [(centre, VISEMES.index(name)) for centre, name in result["decisions"]]
        tracks[result["file"]] = (decisions, result["cpu_s"])
    return tracks


def frames_from(decisions, frames):
    """One viseme per 10 ms frame: the latest decision on audio centred at or before the
    frame's centre (sil before the first)."""
    track = np.zeros(frames, np.int64)
    centres = np.array([c for c, _ in decisions]) if decisions else np.zeros(0)
    names = np.array([v for _, v in decisions], np.int64)
    at = np.searchsorted(centres, frame_centre_s(np.arange(frames)), side="right") - 1
    track[at >= 0] = names[at[at >= 0]]
    return track


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
    parser.add_argument("--calibration", help="a training corpus (make_corpus.py --set train) to calibrate wlipsync from")
    parser.add_argument("--no-npm", action="store_true", help="leave out the npm libraries")
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
    wavs = [(corpus / f"{item['name']}.wav").resolve() for item in items]
    npm = {}
    with tempfile.TemporaryDirectory() as scratch:
        if not args.no_npm:
            if not (BASELINES / "node_modules").is_dir():
                sys.exit(f"the npm libraries are not installed: (cd {BASELINES} && npm ci), or --no-npm")
            print("headaudio ...", file=sys.stderr)
            npm["headaudio"] = npm_tracks(["headaudio.mjs"], wavs)
            if args.calibration:
                for which, system in (("all", "wlipsync, 15 visemes"), ("vowels", "wlipsync, vowels")):
                    profile = Path(scratch) / f"profile-{which}.json"
                    calibrate = ["wlipsync.mjs", "calibrate", str(Path(args.calibration).resolve()), str(profile)]
                    subprocess.run(["node", *calibrate, "--visemes", which], check=True, cwd=BASELINES)
                    print(f"{system} ...", file=sys.stderr)
                    npm[system] = npm_tracks(["wlipsync.mjs", "run", str(profile)], wavs)
            else:
                print("wlipsync left out: no --calibration corpus to calibrate its profile from", file=sys.stderr)
        systems = ["facewire", "energy gate", *npm]
        per_voice = {}
        seconds = dict.fromkeys(systems, 0.0)
        audio_s = 0.0
        for n, (item, wav) in enumerate(zip(items, wavs)):
            samples, _rate = read_wav(str(wav))
            audio_s += len(samples) / 16000
            track, took_s = facewire(args.binary, wav, args.model, Path(scratch))
            seconds["facewire"] += took_s
            started = time.process_time()
            gate = energy_gate(samples)
            seconds["energy gate"] += time.process_time() - started
            labels = frame_labels(corpus / f"{item['name']}.lab", len(track))
            voice = per_voice.setdefault(item["voice"], {system: [] for system in systems})
            voice["facewire"].append((labels, track))
            voice["energy gate"].append((labels, gate))
            for system, tracks in npm.items():
                decisions, cpu_s = tracks[str(wav)]
                seconds[system] += cpu_s
                voice[system].append((labels, frames_from(decisions, len(track))))
            if (n + 1) % 100 == 0:
                print(f"{n + 1} of {len(items)} files", file=sys.stderr)
    voices = sorted(per_voice)
    scores = {v: {system: score(pairs) for system, pairs in per_voice[v].items()} for v in voices}
    print(f"{len(items)} files, {audio_s / 60:.1f} min of held-out speech, {len(voices)} voices\n")
    print("| voice | system | " + " | ".join(title for _, title, _ in MEASURES) + " |")
    print("|---|---|" + "---|" * len(MEASURES))
    for v in voices:
        for system in systems:
            cells = " | ".join(fmt(scores[v][system][key], kind) for key, _, kind in MEASURES)
            print(f"| {v} | {system} | {cells} |")
    print()
    for system, s in seconds.items():
        print(f"{system}: {audio_s / max(s, 1e-9):.0f}x real time on one core")
    for system, ms in LOOK_AHEAD_MS.items():
        if system in npm:
            print(f"{system}: look-ahead {ms:.1f} ms (half its window)")


if __name__ == "__main__":
    main()
