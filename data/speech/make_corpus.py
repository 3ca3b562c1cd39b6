#!/usr/bin/env python3
"""Writes the speech corpus: wav files with phoneme and viseme labels, and an index.

  make_corpus.py OUT_DIR --set train   [--items N] [--seed S] [--jobs J]
  make_corpus.py OUT_DIR --set heldout [--seed S] [--jobs J]

train: N items, a share FESTIVAL_SHARE of them spoken by Festival's TRAIN_FESTIVAL voices
(Italian, Czech, Russian, Finnish, Catalan, Hindi, Marathi, Telugu; none held out) at a
random duration stretch, the rest random sentences (texts.training_sentence) spoken by
eSpeak NG over the TRAIN_ESPEAK voices at random rate and pitch; all augmented
(corpus.draw_augmentation).
heldout: the 40 held-out sentences and 27 syllables spoken, clean and at the voices' own
rate, by every HELDOUT_VOICES voice, none of which speaks in training, plus one copy of
one voice in pink noise at 10 dB SNR.

Per item OUT_DIR gets NAME.wav (16 kHz mono 16-bit) and NAME.lab (start_s, end_s,
phoneme, viseme, tab-separated, covering the file); OUT_DIR/index.tsv lists the items.
Every random choice of item i comes from a generator seeded with (S, set, i), so the
same seed gives the same bytes whatever J.
"""

import argparse
import multiprocessing
import os
import sys
import time
from collections import defaultdict

import numpy as np

import corpus
import texts

# eSpeak NG's English voices (espeak-ng --voices=en, less the mbrola ones) and variants
# (espeak-ng --voices=variant); "" is the voice without a variant.
ESPEAK_ACCENTS = ("en-us", "en", "en-gb-x-rp", "en-gb-x-gbclan", "en-gb-x-gbcwmd", "en-gb-scotland", "en-029", "en-us-nyc")
ESPEAK_VARIANTS = (
    "", "m1", "m2", "m3", "m4", "m5", "m6", "m7", "f1", "f2", "f3", "f4", "f5", "klatt", "klatt2", "klatt3", "croak",
)
# Training never hears this accent nor these variants (7 accents x 14 variants = 98 of the 136 voices).
HELDOUT_ACCENTS = ("en-gb-scotland",)
HELDOUT_VARIANTS = ("m7", "f4", "klatt2")


def espeak_voice(accent, variant):
    """eSpeak NG's name for `accent` with `variant` ("" for none)."""
    return f"{accent}+{variant}" if variant else accent


TRAIN_ESPEAK = tuple(
    espeak_voice(accent, variant)
    for accent in ESPEAK_ACCENTS
    if accent not in HELDOUT_ACCENTS
    for variant in ESPEAK_VARIANTS
    if variant not in HELDOUT_VARIANTS
)
HELDOUT_ESPEAK = ("en-gb-scotland+m7", "en-gb-scotland", "en-us+f4", "en-029+klatt2")
assert not set(HELDOUT_ESPEAK) & set(TRAIN_ESPEAK)

# Held-out voices: (name, synthesizer, the synthesizer's voice).
HELDOUT_VOICES = tuple(("espeak-" + voice, "espeak", voice) for voice in HELDOUT_ESPEAK) + (
    ("festival-kal", "festival", "kal"),
    ("festival-kdl", "festival", "kdl"),
    ("festival-slt-hts", "festival", "slt-hts"),
    ("flite-kal16", "flite", "kal16"),
    ("flite-awb", "flite", "awb"),
    ("flite-rms", "flite", "rms"),
    ("flite-slt", "flite", "slt"),
)
# The noisy copy: (its name, the held-out voice it copies, its augmentation).
NOISY_COPY = ("festival-kal-pink10", "festival-kal", corpus.Augmentation(noise="pink", snr_db=10.0))

# Festival's training voices (keys of corpus.FESTIVAL_VOICES) and the text each reads: "en"
# training_sentence() through its own letter-to-sound rules, or a language of
# texts.NATIVE_WORDS for those whose text processing reads only their own script.
TRAIN_FESTIVAL = {
    "it-lp": "en", "it-pc": "en", "cs-dita": "en", "cs-krb": "en", "cs-machac": "en", "cs-ph": "en",
    "ru-nsh": "ru", "fi-lj": "en", "fi-mv": "en", "ca-ona-hts": "en", "hi-nsk": "hi", "mr-nsk": "mr", "te-nsk": "te",
}
assert not set(TRAIN_FESTIVAL) & {voice for _, synthesizer, voice in HELDOUT_VOICES if synthesizer == "festival"}
FESTIVAL_SHARE = 0.35
FESTIVAL_STRETCHES = (0.75, 1.4)
# Texts drawn for one Festival item before giving up (a text fails when the voice lacks
# one of its diphones: a quarter of English sentences for Italian, most for fi-lj).
FESTIVAL_TRIES = 30

ESPEAK_DEFAULTS = {"rate": 175, "pitch": 50, "pitch_range": 50}
TRAIN_RATES = (110, 320)
BABBLE_BANK = 24
SET_CODES = {"train": 0, "heldout": 1}
COLUMNS = (
    "name", "set", "synthesizer", "voice", "rate", "pitch", "gain_db", "noise", "snr_db", "rt60_s", "telephone", "text",
    "pitch_range", "drr_db", "lead_s", "trail_s", "duration_s",
)

_espeak = None
_bank = []


def espeak():
    """This process's eSpeak NG."""
    global _espeak
    if _espeak is None:
        _espeak = corpus.Espeak()
    return _espeak


def item_rng(seed, set_name, index):
    """The generator of item `index` of `set_name`."""
    return np.random.default_rng((seed, SET_CODES[set_name], index))


def train_speech(seed, index):
    """(choices, samples, segments, rng) of training item `index` before augmentation; the
    augmentation is drawn from rng, the item's generator, next. choices holds the index
    columns synthesizer, voice, rate, pitch, pitch_range and text, and the phone set."""
    rng = item_rng(seed, "train", index)
    if rng.random() < FESTIVAL_SHARE:
        choices, samples, segments = festival_train_speech(rng)
    else:
        choices, samples, segments = espeak_train_speech(rng)
    return choices, corpus.normalised(samples), segments, rng


def espeak_train_speech(rng):
    """(choices, samples, segments) of a training sentence spoken by a TRAIN_ESPEAK voice."""
    voice = TRAIN_ESPEAK[rng.integers(len(TRAIN_ESPEAK))]
    rate = int(rng.integers(TRAIN_RATES[0], TRAIN_RATES[1] + 1))
    pitch, pitch_range = int(rng.integers(0, 100)), int(rng.integers(0, 100))
    text = texts.training_sentence(rng)
    samples, segments = espeak().synth(text, voice, rate, pitch, pitch_range, seed=int(rng.integers(2**32)))
    choices = {"synthesizer": "espeak", "phoneset": "espeak", "voice": "espeak-" + voice, "rate": rate,
               "pitch": pitch, "pitch_range": pitch_range, "text": text}
    return choices, samples, segments


def festival_train_speech(rng):
    """(choices, samples, segments) of a text spoken by a TRAIN_FESTIVAL voice; texts the
    voice fails on (corpus.FestivalFailed) are drawn again, up to FESTIVAL_TRIES."""
    voices = sorted(TRAIN_FESTIVAL)
    voice = voices[rng.integers(len(voices))]
    spec = corpus.FESTIVAL_VOICES[voice]
    stretch = round(float(rng.uniform(*FESTIVAL_STRETCHES)), 3) if spec.stretches else 1.0
    language = TRAIN_FESTIVAL[voice]
    for _ in range(FESTIVAL_TRIES):
        text = texts.training_sentence(rng) if language == "en" else texts.native_text(rng, language)
        try:
            [(samples, segments)] = corpus.festival([(text, voice, stretch)], complete=True)
        except corpus.FestivalFailed:
            continue
        choices = {"synthesizer": "festival", "phoneset": spec.phoneset, "voice": "festival-" + voice,
                   "rate": f"{stretch:.3f}", "pitch": "-", "pitch_range": "-", "text": text}
        return choices, samples, segments
    raise RuntimeError(f"festival voice {voice} failed on {FESTIVAL_TRIES} texts")


def write_item(out_dir, name, samples, segments, phoneset):
    """Writes NAME.wav and NAME.lab (`segments` in `phoneset`); returns the duration in seconds."""
    corpus.write_wav(os.path.join(out_dir, name + ".wav"), samples)
    end = round(len(samples) / corpus.RATE * 1e4)
    ticks = []
    for start_s, end_s, phoneme in segments:
        start, stop = round(start_s * 1e4), min(round(end_s * 1e4), end)
        if stop > start:
            ticks.append((start, stop, phoneme))
    if not ticks or ticks[0][0] != 0 or ticks[-1][1] != end:
        raise RuntimeError(f"{name}: segments do not cover the audio")
    with open(os.path.join(out_dir, name + ".lab"), "w") as lab:
        labels = corpus.visemes(ticks, phoneset)
        for (start, stop, phoneme), viseme in zip(ticks, labels):
            lab.write(f"{start / 1e4:.4f}\t{stop / 1e4:.4f}\t{phoneme}\t{viseme}\n")
    return len(samples) / corpus.RATE


def row(name, set_name, synthesizer, voice, rate, pitch, pitch_range, augmentation, text, duration):
    """The index.tsv row of one item, as {column: text}."""
    a = augmentation

    def number(value, digits):
        """`value` with `digits` decimals, or "-" for None."""
        return "-" if value is None else f"{value:.{digits}f}"

    if "\t" in text or "\n" in text:
        raise ValueError(f"{name}: text has a tab or a newline")
    return {
        "name": name, "set": set_name, "synthesizer": synthesizer, "voice": voice,
        "rate": str(rate), "pitch": str(pitch),
        "gain_db": number(a.gain_db, 2), "noise": a.noise, "snr_db": number(a.snr_db, 2), "rt60_s": number(a.rt60_s, 3),
        "telephone": "yes" if a.telephone else "no", "text": text, "pitch_range": str(pitch_range),
        "drr_db": number(a.drr_db, 2), "lead_s": number(a.lead_s, 3), "trail_s": number(a.trail_s, 3),
        "duration_s": f"{duration:.4f}",
    }


def make_train_item(task):
    """Synthesizes, augments and writes training item `index`; returns its index row."""
    out_dir, seed, index = task
    choices, samples, segments, rng = train_speech(seed, index)
    augmentation = corpus.draw_augmentation(rng)
    bank = [speech for k, speech in enumerate(_bank) if k != index]
    samples, segments = corpus.augment(samples, segments, choices["phoneset"], augmentation, rng, bank)
    name = f"train-{index:06d}"
    duration = write_item(out_dir, name, samples, segments, choices["phoneset"])
    return [row(name, "train", choices["synthesizer"], choices["voice"], choices["rate"], choices["pitch"],
                choices["pitch_range"], augmentation, choices["text"], duration)]


def heldout_texts():
    """[(item suffix, text)] of the held-out set: sentences, then syllables."""
    sentences = [(f"sent{k + 1:02d}", text) for k, text in enumerate(texts.HELDOUT_SENTENCES)]
    return sentences + [(f"syl-{cv}", spelling) for cv, spelling in texts.HELDOUT_SYLLABLES]


def heldout_speech(synthesizer, voice, seeds):
    """[(suffix, text, samples, segments)] of every held-out text spoken by one voice, clean;
    `seeds` are the items' generators (eSpeak NG's noise sources take a seed from them)."""
    items = heldout_texts()
    if synthesizer == "festival":
        spoken = corpus.festival([(text, voice, 1.0) for _, text in items])
    elif synthesizer == "flite":
        spoken = [corpus.flite(text, voice) for _, text in items]
    else:
        spoken = [
            espeak().synth(text, voice, **ESPEAK_DEFAULTS, seed=int(rng.integers(2**32)))
            for (_, text), rng in zip(items, seeds)
        ]
    return [
        (suffix, text, corpus.normalised(samples), segments)
        for (suffix, text), (samples, segments) in zip(items, spoken)
    ]


def make_heldout_voice(task):
    """Writes every held-out item of one voice (or of the noisy copy), the voice being task
    number `position`; returns their index rows."""
    out_dir, seed, position, name = task
    noisy = name == NOISY_COPY[0]
    source = NOISY_COPY[1] if noisy else name
    _, synthesizer, voice = next(v for v in HELDOUT_VOICES if v[0] == source)
    count = len(heldout_texts())
    seeds = [item_rng(seed, "heldout", position * count + k) for k in range(count)]
    if synthesizer == "espeak":
        rate, pitch, pitch_range = ESPEAK_DEFAULTS["rate"], ESPEAK_DEFAULTS["pitch"], ESPEAK_DEFAULTS["pitch_range"]
    else:
        rate, pitch, pitch_range = "1.0", "-", "-"
    rows = []
    for rng, (suffix, text, samples, segments) in zip(seeds, heldout_speech(synthesizer, voice, seeds)):
        augmentation = NOISY_COPY[2] if noisy else corpus.Augmentation()
        if noisy:
            samples, segments = corpus.augment(samples, segments, synthesizer, augmentation, rng)
        item = f"{name}-{suffix}"
        duration = write_item(out_dir, item, samples, segments, synthesizer)
        rows.append(row(item, "heldout", synthesizer, name, rate, pitch, pitch_range, augmentation, text, duration))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument("--set", required=True, choices=("train", "heldout"))
    parser.add_argument("--items", type=int, default=3000, help="training items (train only; default 3000)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=os.cpu_count(), help="worker processes (default: one per core)")
    args = parser.parse_args()
    os.makedirs(args.out_dir, exist_ok=True)
    started = time.monotonic()
    if args.set == "train":
        print(f"babble bank: the clean speech of training items 0-{BABBLE_BANK - 1}", file=sys.stderr)
        _bank.extend(train_speech(args.seed, i)[1] for i in range(BABBLE_BANK))
        worker, tasks = make_train_item, [(args.out_dir, args.seed, i) for i in range(args.items)]
    else:
        names = [voice[0] for voice in HELDOUT_VOICES] + [NOISY_COPY[0]]
        worker, tasks = make_heldout_voice, [(args.out_dir, args.seed, k, name) for k, name in enumerate(names)]
    rows = []
    with multiprocessing.get_context("fork").Pool(max(1, args.jobs)) as pool:
        for done, task_rows in enumerate(pool.imap(worker, tasks), 1):
            rows.extend(task_rows)
            if done == len(tasks) or done % max(1, len(tasks) // 20) == 0 or args.set == "heldout":
                label = task_rows[0]["voice"] if args.set == "heldout" else f"{done}/{len(tasks)}"
                print(f"  {label}: {time.monotonic() - started:.1f} s", file=sys.stderr)
    with open(os.path.join(args.out_dir, "index.tsv"), "w") as index:
        index.write("\t".join(COLUMNS) + "\n")
        for r in rows:
            index.write("\t".join(r[c] for c in COLUMNS) + "\n")
    summarize(rows, time.monotonic() - started)


def summarize(rows, elapsed):
    """Prints the items, hours of audio and time taken, and each voice's share (stderr)."""
    per_voice = defaultdict(lambda: [0, 0.0])
    for r in rows:
        per_voice[r["voice"]][0] += 1
        per_voice[r["voice"]][1] += float(r["duration_s"])
    total = sum(seconds for _, seconds in per_voice.values())
    print(f"{len(rows)} items, {total / 3600:.3f} h of audio, in {elapsed:.1f} s", file=sys.stderr)
    for voice, (count, seconds) in sorted(per_voice.items()):
        print(f"  {voice}\t{count} items\t{seconds:.1f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
