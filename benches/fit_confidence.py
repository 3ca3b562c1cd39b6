#!/usr/bin/env python3
"""Does the learned reading know when the automatic fit is wrong? (docs/FITTING.md, "On a
population"). Reads `facewire population --json` and ranks the fits by three readings
against their true error (the landmark mask vertices' mean distance from the reference
fit's, mm): the marks' raw mean distance from their mask vertices, and that distance
after each mark's systematic offset from its vertex (the mean over the development
members, in the mask's axes) is taken away, for the development members (leave one out)
and for the held-out ones (offsets from the development members only). Prints Spearman's
rank correlation (and Pearson's) for each.

    ./target/release/facewire population --json > pop.jsonl
    python3 benches/fit_confidence.py pop.jsonl
"""

import json
import math
import sys
from collections import defaultdict


def ranks(xs):
    order = sorted(range(len(xs)), key=lambda i: xs[i])
    out = [0] * len(xs)
    for rank, i in enumerate(order):
        out[i] = rank
    return out


def pearson(a, b):
    n = len(a)
    ma, mb = sum(a) / n, sum(b) / n
    cov = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    return cov / math.sqrt(sum((x - ma) ** 2 for x in a) * sum((y - mb) ** 2 for y in b))


def spearman(a, b):
    return pearson(ranks(a), ranks(b))


def mean_offsets(members):
    offsets = defaultdict(list)
    for m in members:
        for vertex, offset in m["mark_offsets_mm"]:
            offsets[vertex].append(offset)
    return {v: [sum(o[i] for o in os) / len(os) for i in range(3)] for v, os in offsets.items()}


def residual(member, means):
    distances = [math.dist(offset, means[vertex]) for vertex, offset in member["mark_offsets_mm"] if vertex in means]
    return sum(distances) / max(len(distances), 1)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    rows = [json.loads(line) for line in open(sys.argv[1]) if line.startswith("{")]
    fitted = [dict(r["result"]["Ok"], held_out=r["held_out"]) for r in rows if "Ok" in r["result"]]
    dev = [m for m in fitted if not m["held_out"]]
    held = [m for m in fitted if m["held_out"]]
    means = mean_offsets(dev)
    loo = [residual(m, mean_offsets([d for d in dev if d is not m])) for m in dev]
    print("| members | n | raw marks distance | less each mark's learned offset |")
    print("|---|---|---|---|")
    for name, group, corrected in [
        ("development (leave one out)", dev, loo),
        ("held out", held, [residual(m, means) for m in held]),
    ]:
        error = [m["landmark_mean_mm"] for m in group]
        raw = [m["marks_mean_mm"] for m in group]
        print(f"| {name} | {len(group)} | {spearman(raw, error):.2f} ({pearson(raw, error):.2f}) "
              f"| {spearman(corrected, error):.2f} ({pearson(corrected, error):.2f}) |")


if __name__ == "__main__":
    main()
