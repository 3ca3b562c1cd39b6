"""How a viseme track is scored against the synthesizer's own timing, for train.py and
benches/speech_visemes.py (definitions in docs/SPEECH.md, "Measures").

Frames are 10 ms steps; frame i is centred at (160 i + 200) / 16000 s, as in
core/src/speech/log_mel.rs. A track is one viseme index (into corpus.VISEMES) per frame.
"""

import numpy as np

from corpus import VISEMES

FRAME_S = 0.01
# The five mouth shapes a lip-reader tells apart, by viseme.
MOUTH_CLASSES = ("closed", "labiodental", "open", "rounded", "spread")
MOUTH_CLASS_OF = {
    "sil": None,
    "PP": "closed",
    "FF": "labiodental",
    "aa": "open",
    "E": "open",
    "kk": "open",
    "nn": "open",
    "DD": "open",
    "oh": "rounded",
    "ou": "rounded",
    "RR": "rounded",
    "CH": "rounded",
    "ih": "spread",
    "SS": "spread",
    "TH": "spread",
}
# A found run may start or end this far outside the true one.
MATCH_TOLERANCE_FRAMES = 10
PP, FF = VISEMES.index("PP"), VISEMES.index("FF")
_CLASS = np.array([-1 if MOUTH_CLASS_OF[v] is None else MOUTH_CLASSES.index(MOUTH_CLASS_OF[v]) for v in VISEMES])


def frame_centre_s(i):
    return (np.asarray(i) * 160 + 200) / 16000


def frame_labels(lab_path, frames):
    """The viseme of the segment under each frame's centre (sil past the last one)."""
    starts, visemes = [], []
    with open(lab_path) as lab:
        for line in lab:
            start, end, _phoneme, viseme = line.rstrip("\n").split("\t")
            starts.append(float(start))
            visemes.append(VISEMES.index(viseme))
    centre = frame_centre_s(np.arange(frames))
    at = np.searchsorted(np.array(starts), centre, side="right") - 1
    labels = np.array(visemes)[np.clip(at, 0, len(visemes) - 1)]
    labels[centre >= float(end)] = 0
    return labels


def runs(track, viseme):
    """(first, last) frame of each maximal run of `viseme`."""
    is_v = np.concatenate([[False], np.asarray(track) == viseme, [False]])
    edges = np.flatnonzero(np.diff(is_v.astype(np.int8)))
    return list(zip(edges[0::2], edges[1::2] - 1))


def match(truth, found):
    """Pairs each true run with the found run that starts nearest it among those
    overlapping it widened by the tolerance; each found run pairs once."""
    pairs, used = [], set()
    for t0, t1 in truth:
        near = [
            (abs(f0 - t0), k)
            for k, (f0, f1) in enumerate(found)
            if k not in used and f0 <= t1 + MATCH_TOLERANCE_FRAMES and f1 >= t0 - MATCH_TOLERANCE_FRAMES
        ]
        if near:
            k = min(near)[1]
            used.add(k)
            pairs.append(((t0, t1), found[k]))
    return pairs


def score(pairs):
    """Scores [(true labels, decided track)] of one voice; every figure a plain float
    (None where nothing could be measured)."""
    speech_hits = speech_frames = class_hits = 0
    events = {"PP": [0, 0, 0, []], "FF": [0, 0, 0, []]}  # true runs, found runs, paired, onset errors
    signed = []
    for labels, track in pairs:
        labels, track = np.asarray(labels), np.asarray(track)
        speech = labels != 0
        speech_frames += int(speech.sum())
        speech_hits += int((labels[speech] == track[speech]).sum())
        class_hits += int((_CLASS[labels[speech]] == _CLASS[track[speech]]).sum())
        for viseme in range(1, len(VISEMES)):
            truth, found = runs(labels, viseme), runs(track, viseme)
            paired = match(truth, found)
            onsets = [(f[0] - t[0]) * FRAME_S * 1000 for t, f in paired]
            signed.extend(onsets)
            name = VISEMES[viseme]
            if name in events:
                e = events[name]
                e[0] += len(truth)
                e[1] += len(found)
                e[2] += len(paired)
                e[3].extend(abs(o) for o in onsets)
    result = {
        "speech_frames": speech_frames,
        "accuracy15": speech_hits / max(speech_frames, 1),
        "accuracy5": class_hits / max(speech_frames, 1),
        "mean_lag_ms": float(np.mean(signed)) if signed else None,
    }
    for name, (truth, found, paired, onset) in events.items():
        result[f"{name}_recall"] = paired / truth if truth else None
        result[f"{name}_precision"] = paired / found if found else None
        result[f"{name}_onset_median_ms"] = float(np.median(onset)) if onset else None
        result[f"{name}_onset_p90_ms"] = float(np.percentile(onset, 90)) if onset else None
    return result
