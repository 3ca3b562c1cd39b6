"""Trains facewire's speech-to-viseme model (data/speech/visemes.safetensors).

    python3 data/speech/train.py TRAIN_DIR TRAIN_FEATURES OUT.safetensors
        [--validate-voices 6] [--epochs 12] [--seed 1] [--report HELDOUT_DIR HELDOUT_FEATURES]

TRAIN_DIR is a corpus from make_corpus.py (its .lab files and index.tsv), TRAIN_FEATURES
the log-mel frames of its wav files written by facewire itself
(`cargo run --release --example speech_features -- TRAIN_DIR TRAIN_FEATURES`), so the model
learns from exactly the frames the server computes.

What it makes (read by core/src/speech/model.rs, documented in docs/SPEECH.md):
- the input normalization the tracker applies frame by frame (a running mean of the
  log-mel bands, updated only on frames within `gate` of the decaying peak level, a fixed
  per-band scale, and the loudness of the frame under that peak); this file replays it
  exactly, in float32, so training sees what the server sees;
- a multilayer perceptron over a window of normalized frames (`context`: 24 frames back,
  4 ahead, so 40 ms of look-ahead plus the 12.5 ms half analysis window), ReLU, softmax
  over the 15 visemes, trained with Adam on cross-entropy, seeded;
- the viseme prior and 10 ms transition matrix of the training labels for the tracker's
  forward filter.

The voices named by --validate-voices are held out of the fit and pick the epoch kept
(early stopping); --report scores the model on a held-out corpus after training and
changes nothing. The same inputs and seed give the same file on the same machine (one
BLAS thread).
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one thread: a reproducible sum order

import numpy as np  # noqa: E402
from safetensors.numpy import load_file, save_file  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus import VISEMES  # noqa: E402
from scoring import frame_labels, score  # noqa: E402

FORMAT = "facewire-visemes-1"
MELS = 40
FEATURES = MELS + 1
CONTEXT = (-24, -18, -13, -9, -6, -4, -2, -1, 0, 1, 2, 3, 4)
HIDDEN = (256, 256)
# Normalization constants, in natural-log power units per 10 ms frame.
MEAN_RATE = 0.01  # the running mean's step: a time constant of 1 s of speech
PEAK_DECAY = 0.0023  # the peak level falls 1 dB per second
GATE = 6.9  # frames more than 30 dB under the peak do not move the mean
LOUDNESS_SCALE = 0.1
TRANSITION_FLOOR = 1e-4


def f32(x):
    return np.float32(x)


def normalize(raw, mean_init, inv_std):
    """The tracker's normalization of one file's raw log-mel frames, in float32, frame by
    frame as core/src/speech/tracker.rs does it."""
    n = len(raw)
    out = np.empty((n, FEATURES), np.float32)
    mean = mean_init.astype(np.float32).copy()
    rate, decay, gate, scale = f32(MEAN_RATE), f32(PEAK_DECAY), f32(GATE), f32(LOUDNESS_SCALE)
    peak = None
    for i in range(n):
        x = raw[i]
        level = f32(x.sum(dtype=np.float32) / f32(MELS))
        peak = level if peak is None else max(level, f32(peak - decay))
        if level > peak - gate:
            mean += rate * (x - mean)
        out[i, :MELS] = (x - mean) * inv_std
        out[i, MELS] = (level - peak) * scale
    return out


def read_corpus(corpus_dir, features_path):
    """[(name, voice, raw log-mel (frames, 40), viseme label per frame)] in index order."""
    features = load_file(features_path)
    rows = []
    with open(Path(corpus_dir) / "index.tsv") as index:
        header = index.readline().rstrip("\n").split("\t")
        for line in index:
            item = dict(zip(header, line.rstrip("\n").split("\t")))
            name = item["name"]
            raw = features[name]
            labels = frame_labels(Path(corpus_dir) / f"{name}.lab", len(raw))
            rows.append((name, item["voice"], raw, labels))
    return rows


def normalization_constants(rows):
    """The mean the tracker starts from (of frames within the gate of their file's
    loudest) and the per-band scale that gives the normalized bands unit spread."""
    gated = []
    for _, _, raw, _ in rows:
        level = raw.mean(1)
        gated.append(raw[level > level.max() - GATE])
    mean_init = np.concatenate(gated).mean(0).astype(np.float32)
    ones = np.ones(MELS, np.float32)
    centred = np.concatenate([normalize(raw, mean_init, ones)[:, :MELS] for _, _, raw, _ in rows])
    inv_std = (1.0 / np.maximum(centred.std(0), 1e-3)).astype(np.float32)
    return mean_init, inv_std


class Frames:
    """All files' normalized frames end to end, and for each frame the rows of its
    context window (clamped to its own file, as the tracker clamps at the stream's ends)."""

    def __init__(self, normalized, labels):
        self.features = np.concatenate(normalized)
        self.labels = np.concatenate(labels).astype(np.int64)
        starts = np.cumsum([0] + [len(f) for f in normalized])
        first = np.repeat(starts[:-1], [len(f) for f in normalized])
        last = np.repeat(starts[1:] - 1, [len(f) for f in normalized])
        at = np.arange(len(self.features))[:, None] + np.array(CONTEXT)[None, :]
        self.window = np.clip(at, first[:, None], last[:, None]).astype(np.int64)

    def inputs(self, frames):
        return self.features[self.window[frames]].reshape(len(frames), -1)


def init_layers(rng, inputs):
    layers = []
    for outputs in (*HIDDEN, len(VISEMES)):
        weight = rng.standard_normal((outputs, inputs)).astype(np.float32) * np.float32(np.sqrt(2.0 / inputs))
        layers.append([weight, np.zeros(outputs, np.float32)])
        inputs = outputs
    return layers


def forward(layers, x):
    activations = [x]
    for i, (w, b) in enumerate(layers):
        x = x @ w.T + b
        if i + 1 < len(layers):
            x = np.maximum(x, 0)
        activations.append(x)
    return activations


def softmax(logits):
    e = np.exp(logits - logits.max(1, keepdims=True))
    return e / e.sum(1, keepdims=True)


def train(frames, validation, rng, epochs, batch=256, lr=1e-3, weight_decay=1e-5):
    layers = init_layers(rng, len(CONTEXT) * FEATURES)
    moments = [[np.zeros_like(p) for p in layer] for layer in layers]
    squares = [[np.zeros_like(p) for p in layer] for layer in layers]
    beta1, beta2, step = 0.9, 0.999, 0
    best = (-1.0, None, 0)
    for epoch in range(epochs):
        started = time.time()
        rate = lr * 0.5 * (1 + np.cos(np.pi * epoch / epochs))  # cosine schedule
        order = rng.permutation(len(frames.labels))
        loss_sum = 0.0
        for begin in range(0, len(order) - batch + 1, batch):
            chosen = order[begin : begin + batch]
            activations = forward(layers, frames.inputs(chosen))
            p = softmax(activations[-1])
            target = frames.labels[chosen]
            loss_sum += -np.log(p[np.arange(batch), target] + 1e-12).sum()
            grad = p
            grad[np.arange(batch), target] -= 1
            grad /= batch
            step += 1
            for i in range(len(layers) - 1, -1, -1):
                w, b = layers[i]
                gw = grad.T @ activations[i] + weight_decay * w
                gb = grad.sum(0)
                if i > 0:
                    grad = (grad @ w) * (activations[i] > 0)
                for j, g in enumerate((gw, gb)):
                    moments[i][j] = beta1 * moments[i][j] + (1 - beta1) * g
                    squares[i][j] = beta2 * squares[i][j] + (1 - beta2) * g * g
                    m = moments[i][j] / (1 - beta1**step)
                    v = squares[i][j] / (1 - beta2**step)
                    layers[i][j] -= (rate * m / (np.sqrt(v) + 1e-8)).astype(np.float32)
        accuracy = speech_accuracy(layers, validation)
        print(
            f"epoch {epoch + 1}/{epochs}: loss {loss_sum / len(order):.3f}, "
            f"validation speech-frame accuracy {accuracy:.3f} ({time.time() - started:.0f} s)",
            flush=True,
        )
        if accuracy > best[0]:
            best = (accuracy, [[p.copy() for p in layer] for layer in layers], epoch + 1)
    print(f"kept epoch {best[2]} (validation {best[0]:.3f})")
    return best[1]


def posteriors(layers, frames):
    out = np.empty((len(frames.labels), len(VISEMES)), np.float32)
    for begin in range(0, len(out), 4096):
        chosen = np.arange(begin, min(begin + 4096, len(out)))
        out[chosen] = softmax(forward(layers, frames.inputs(chosen))[-1])
    return out


def speech_accuracy(layers, frames):
    speech = frames.labels != 0
    return float((posteriors(layers, frames).argmax(1)[speech] == frames.labels[speech]).mean())


def decoder(labels):
    """The prior and the 10 ms transition matrix of the training labels."""
    k = len(VISEMES)
    prior = np.bincount(np.concatenate(labels), minlength=k).astype(np.float64)
    prior /= prior.sum()
    counts = np.zeros((k, k))
    for file_labels in labels:
        np.add.at(counts, (file_labels[:-1], file_labels[1:]), 1)
    transition = counts / np.maximum(counts.sum(1, keepdims=True), 1)
    transition = np.maximum(transition, TRANSITION_FLOOR)
    transition /= transition.sum(1, keepdims=True)
    return prior.astype(np.float32), transition.astype(np.float32)


def filtered(posterior, prior, transition):
    """The tracker's forward filter over one file's posteriors."""
    out = np.empty_like(posterior)
    state = None
    for t, post in enumerate(posterior):
        reach = prior if state is None else state @ transition
        state = post / np.maximum(prior, 1e-6) * reach
        total = state.sum()
        state = state / total if total > 0 and np.isfinite(total) else post
        out[t] = state
    return out


def file_decisions(layers, normalized, prior, transition):
    """Per file, the tracker's decided viseme of every frame."""
    decided = []
    for features in normalized:
        frames = Frames([features], [np.zeros(len(features), np.int64)])
        decided.append(filtered(posteriors(layers, frames), prior, transition).argmax(1))
    return decided


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("train_dir")
    parser.add_argument("train_features")
    parser.add_argument("out")
    parser.add_argument("--validate-voices", type=int, default=6, help="training voices kept out of the fit")
    parser.add_argument("--epochs", type=int, default=12)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--report", nargs=2, metavar=("HELDOUT_DIR", "HELDOUT_FEATURES"))
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)

    rows = read_corpus(args.train_dir, args.train_features)
    voices = sorted({voice for _, voice, _, _ in rows})
    validate = set(rng.choice(voices, size=args.validate_voices, replace=False).tolist())
    print(f"{len(rows)} files, {len(voices)} voices; validation voices: {', '.join(sorted(validate))}")
    mean_init, inv_std = normalization_constants([r for r in rows if r[1] not in validate])
    normalized = [normalize(raw, mean_init, inv_std) for _, _, raw, _ in rows]
    fit = [i for i, r in enumerate(rows) if r[1] not in validate]
    held = [i for i, r in enumerate(rows) if r[1] in validate]
    frames = Frames([normalized[i] for i in fit], [rows[i][3] for i in fit])
    validation = Frames([normalized[i] for i in held], [rows[i][3] for i in held])
    print(f"{len(frames.labels)} training frames, {len(validation.labels)} validation frames")
    layers = train(frames, validation, rng, args.epochs)
    prior, transition = decoder([rows[i][3] for i in fit])

    tensors = {"feature_mean": mean_init, "feature_inv_std": inv_std, "viseme_prior": prior, "viseme_transition": transition}
    for i, (w, b) in enumerate(layers):
        tensors[f"dense{i}.weight"] = np.ascontiguousarray(w)
        tensors[f"dense{i}.bias"] = b
    # A parity check for src/speech: one validation file's raw frames and the filtered
    # probabilities this trainer computes for them.
    check = held[0]
    check_raw = rows[check][2][:300]
    check_frames = Frames([normalize(check_raw, mean_init, inv_std)], [np.zeros(len(check_raw), np.int64)])
    tensors["check.log_mel"] = np.ascontiguousarray(check_raw)
    tensors["check.probability"] = filtered(posteriors(layers, check_frames), prior, transition)
    metadata = {
        "format": FORMAT,
        "context": ",".join(str(c) for c in CONTEXT),
        "mean_rate": repr(MEAN_RATE),
        "peak_decay": repr(PEAK_DECAY),
        "gate": repr(GATE),
        "loudness_scale": repr(LOUDNESS_SCALE),
        "visemes": ",".join(VISEMES),
        "trained_on": f"{len(fit)} files of {args.train_dir} ({len(voices) - len(validate)} voices), seed {args.seed}",
    }
    save_file(tensors, args.out, metadata=metadata)
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e6:.2f} MB)")

    if args.report:
        report_rows = read_corpus(*args.report)
        report_normalized = [normalize(raw, mean_init, inv_std) for _, _, raw, _ in report_rows]
        decided = file_decisions(layers, report_normalized, prior, transition)
        by_voice = {}
        for (_, voice, _, labels), d in zip(report_rows, decided):
            by_voice.setdefault(voice, []).append((labels, d))
        for voice, pairs in sorted(by_voice.items()):
            print(voice, json.dumps(score(pairs)))


if __name__ == "__main__":
    main()
