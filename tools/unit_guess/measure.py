#!/usr/bin/env python3
"""Measure how well a head's unit can be guessed from lengths across its fitted face.

A head file rarely says its unit. The automatic fit guesses it from the pupils (63 mm apart,
the standard unit within 15 % taken when there is one: core/src/fit/automatic/mod.rs). This
script measures that guess's spread, the uncertainty the fit reports (PUPILS_RELATIVE_SD),
and whether seven lengths across the fitted CANDIDE-3 mask (core/src/fit/face_lengths.rs:
pupils, inner and outer eye corners, mouth width, eyes to nose, nose to mouth, nose to
chin) would do better, combined as one estimate of log(mm per head unit):

    log m = sum_c w_c (mu_c - log L_c)        (sum_c w_c = 1)

with L_c the length in head units, mu_c the mean of log(length in mm) over the development
members, and w the generalized least-squares weights of their covariance S (the minimum-
variance unbiased combination: w = S^-1 1 / (1' S^-1 1)), S shrunk toward its diagonal by
a share chosen by five-fold cross-validation over the development members alone (a head's
variants in one fold). The held-out members are only reported.

Data: `facewire population --json` (each member's `face_lengths_mm`, at the true scale):

    ./target/release/facewire population --json > /tmp/population.jsonl
    python3 tools/unit_guess/measure.py /tmp/population.jsonl

Needs numpy.
"""
import json
import sys

import numpy as np

FOLDS = 5
SHRINKS = [0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0]
# What the fit assumed before (core/src/fit/mod.rs ASSUMED_PUPIL_SEPARATION_MM), for
# comparison only.
PUPILS_MM = 63.0


def load(path):
    """The members that were fitted, and the lengths' names in the order the fit wrote them."""
    members, names = [], None
    for line in open(path):
        row = json.loads(line)
        fit = row["result"].get("Ok")
        if fit is None:
            continue
        lengths = fit["face_lengths_mm"]
        if names is None:
            names = list(lengths)
        members.append({
            "name": row["member"],
            "held_out": row["held_out"],
            "log_mm": np.log([lengths[n] for n in names]),
            # Variants of one head (its face cut, low-poly, turned) share a fold.
            "identity": row["member"].split(",")[0].split(" turned")[0],
        })
    return members, names


def model(log_mm, shrink):
    """(mu, weights, sd of the combined log estimate) from rows of log lengths in mm."""
    mu = log_mm.mean(axis=0)
    cov = np.cov(log_mm, rowvar=False)
    cov = (1.0 - shrink) * cov + shrink * np.diag(np.diag(cov))
    inverse_ones = np.linalg.solve(cov, np.ones(cov.shape[0]))
    total = inverse_ones.sum()
    return mu, inverse_ones / total, float(np.sqrt(1.0 / total))


def errors(members, mu, weights):
    """Each member's guess over the true unit, minus one: the guess is exp(sum w (mu - log
    L)), with L in head units; in mm at the true scale the truth is 1."""
    return np.array([np.exp(weights @ (mu - m["log_mm"])) - 1.0 for m in members])


def folds(members):
    identities = sorted({m["identity"] for m in members})
    fold_of = {name: k % FOLDS for k, name in enumerate(identities)}
    return [fold_of[m["identity"]] for m in members]


def cross_validated(members, shrink):
    fold = folds(members)
    out = np.zeros(len(members))
    for f in range(FOLDS):
        train = np.array([m["log_mm"] for m, k in zip(members, fold) if k != f])
        mu, weights, _ = model(train, shrink)
        test = [i for i, k in enumerate(fold) if k == f]
        out[test] = errors([members[i] for i in test], mu, weights)
    return out


def summary(name, e):
    rms = float(np.sqrt(np.mean(np.log1p(e) ** 2)))
    return (f"{name}: {len(e)} members, rms {100 * rms:.1f} %, within 5 % {int((np.abs(e) <= 0.05).sum())}, "
            f"within 15 % {int((np.abs(e) <= 0.15).sum())}, worst {100 * e[np.abs(e).argmax()]:+.1f} %")


def main():
    if len(sys.argv) != 2:
        raise SystemExit("usage: measure.py POPULATION.jsonl")
    members, names = load(sys.argv[1])
    if not names or names[0] != "pupils":
        raise SystemExit(f"{sys.argv[1]}: the first face length is {names and names[0]!r}, not the pupils")
    development = [m for m in members if not m["held_out"]]
    held_out = [m for m in members if m["held_out"]]
    if len(development) < 2 * len(names):
        raise SystemExit(f"{len(development)} development members: too few for {len(names)} lengths")
    scores = {s: float(np.sqrt(np.mean(np.log1p(cross_validated(development, s)) ** 2))) for s in SHRINKS}
    for s, rms in scores.items():
        print(f"lengths combined, covariance shrunk {s:.2f} toward its diagonal: cross-validated rms {100 * rms:.2f} %")
    shrink = min(scores, key=scores.get)
    mu, weights, sd = model(np.array([m["log_mm"] for m in development]), shrink)
    print(f"chosen shrink {shrink:g}: weights " + ", ".join(f"{n} {w:+.2f}" for n, w in zip(names, weights))
          + f"; the covariance predicts {100 * sd:.2f} %")
    pupils = lambda ms: np.array([PUPILS_MM / np.exp(m["log_mm"][0]) - 1.0 for m in ms])
    print(summary("development, lengths combined (cross-validated)", cross_validated(development, shrink)))
    print(summary("development, pupils alone", pupils(development)))
    if held_out:
        print(summary("held out, lengths combined", errors(held_out, mu, weights)))
        print(summary("held out, pupils alone", pupils(held_out)))
    log_mm = np.array([m["log_mm"] for m in development])
    print("correlation of the lengths' logs (development):")
    for name, row in zip(names, np.corrcoef(log_mm, rowvar=False)):
        print(f"  {name:18s} " + " ".join(f"{c:5.2f}" for c in row))
    print("spread of each length (sd of its log, %): "
          + ", ".join(f"{n} {100 * v:.1f}" for n, v in zip(names, log_mm.std(axis=0))))


if __name__ == "__main__":
    main()
