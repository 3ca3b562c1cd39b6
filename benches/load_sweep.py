#!/usr/bin/env python3
"""Load sweeps for docs/PERFORMANCE.md: `facewire serve` with raised limits and
`facewire load` against it, on this machine, printing one Markdown table per sweep.

    python3 benches/load_sweep.py target/release/facewire [seconds] [--chart SVG] [--json FILE]

Sweeps: viewers at 50 streams, and streams at 4 viewers each, for the default algorithm
and for H (`point_distance:k=all`, the slowest preset on the MakeHuman head). A short
warm-up run comes first; a sweep stops after two points in a row past the knee (p99 over
20 ms or any stall), since one point alone can be an outlier on a shared machine. Then the
same loads as FWF1 and as the naive JSON baseline (`--format json`), side by side."""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CONFIG = """[limits]
max_streams_per_head = 10000
max_viewers = 100000
max_connections = 100000
"""


def serve(binary, folder):
    config = Path(folder) / "load.toml"
    config.write_text(CONFIG)
    server = subprocess.Popen(
        [binary, "serve", "--addr", "127.0.0.1:0", "--config", str(config), "--data-dir", str(Path(folder) / "data")],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    line = server.stdout.readline().strip()
    url = line.removeprefix("facewire listening on ").rstrip("/")
    return server, url


def load(binary, url, streams, viewers, seconds, algo, folder, wire="fwf1"):
    out = Path(folder) / "load.json"
    args = [binary, "load", "--url", url, "--streams", str(streams), "--viewers", str(viewers), "--seconds", str(seconds), "--json", str(out), "--format", wire]
    if algo:
        args += ["--algo", algo]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.loads(out.read_text())


HEADER = (
    "| streams | viewers | received | stalls (producer's) | p50 ms | p99 ms | max ms | server CPU % of a core | generator CPU % | server MiB |\n"
    "|---|---|---|---|---|---|---|---|---|---|"
)


def row(r):
    received = 100.0 * r["frames_received"] / max(r["frames_expected"], 1)
    lat = r["latency_ms"]
    server = r["server"] or {}
    return (
        f"| {r['streams']} | {r['viewers']} | {received:.1f} % | {r['stalls']} ({r['producer_stalls']}) | {lat['p50']:.2f} | "
        f"{lat['p99']:.2f} | {lat['max']:.1f} | {server.get('cpu_percent', float('nan')):.0f} | "
        f"{r['generator_cpu_percent']:.0f} | {server.get('resident_mib_after', float('nan')):.1f} |"
    )


def past_knee(r):
    return r["latency_ms"]["p99"] > 20.0 or r["stalls"] > 0


def sweep(binary, url, title, points, seconds, algo, folder):
    """Runs `points` until two in a row are past the knee; returns their reports."""
    print(f"\n**{title}**\n")
    print(HEADER)
    reports, beyond = [], 0
    for streams, viewers in points:
        r = load(binary, url, streams, viewers, seconds, algo, folder)
        reports.append(r)
        print(row(r), flush=True)
        beyond = beyond + 1 if past_knee(r) else 0
        if beyond == 2:
            break
        time.sleep(1)
    return reports


def baseline(binary, url, points, seconds, folder):
    """The same loads as FWF1 and as the naive JSON baseline, alternating."""
    print("\n**FWF1 against the JSON baseline, default algorithm (V)**\n")
    print("| streams | viewers | format | bytes per frame | p50 ms | p99 ms | stalls | server CPU % of a core | bytes ratio | CPU ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    pairs = []
    for streams, viewers in points:
        fwf1 = load(binary, url, streams, viewers, seconds, "", folder, "fwf1")
        time.sleep(1)
        naive = load(binary, url, streams, viewers, seconds, "", folder, "json")
        time.sleep(1)
        bytes_ratio = naive["bytes_per_frame"] / max(fwf1["bytes_per_frame"], 1)
        cpu_ratio = naive["server"]["cpu_percent"] / max(fwf1["server"]["cpu_percent"], 1e-9)
        for r, ratios in ((fwf1, ""), (naive, f" {bytes_ratio:.0f}x | {cpu_ratio:.2f}x |")):
            lat = r["latency_ms"]
            print(
                f"| {streams} | {viewers} | {r['format']} | {r['bytes_per_frame']:,.0f} | {lat['p50']:.2f} | {lat['p99']:.2f} | "
                f"{r['stalls']} | {r['server']['cpu_percent']:.0f} |{ratios or ' | |'}",
                flush=True,
            )
        pairs.append((fwf1, naive))
    return pairs


def chart(series, path):
    """An SVG line chart of p99 latency against viewers, one line per series, log scale."""
    import math

    width, height, left, bottom, top, right = 680, 360, 60, 40, 20, 170
    xs = [r["viewers"] for _, reports in series for r in reports]
    x_max = max(xs) * 1.05
    y_min, y_max = 1.0, 500.0
    px = lambda v: left + (width - left - right) * v / x_max
    py = lambda ms: top + (height - top - bottom) * (1 - (math.log10(max(ms, y_min)) - 0) / math.log10(y_max))
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="11">',
           f'<rect width="{width}" height="{height}" fill="white"/>']
    for ms in (1, 2, 5, 10, 20, 50, 100, 200, 500):
        y = py(ms)
        colour = "#d33" if ms == 20 else "#ddd"
        out.append(f'<line x1="{left}" x2="{width - right}" y1="{y:.1f}" y2="{y:.1f}" stroke="{colour}"/>')
        out.append(f'<text x="{left - 6}" y="{y + 4:.1f}" text-anchor="end">{ms}</text>')
    step = 200 if x_max < 2500 else 500
    for v in range(0, int(x_max) + 1, step):
        out.append(f'<text x="{px(v):.1f}" y="{height - bottom + 16}" text-anchor="middle">{v}</text>')
    out.append(f'<text x="{(left + width - right) / 2}" y="{height - 6}" text-anchor="middle">viewers (50 streams at 30 fps, or 4 viewers a stream)</text>')
    out.append(f'<text x="14" y="{top + (height - top - bottom) / 2}" transform="rotate(-90 14 {top + (height - top - bottom) / 2})" text-anchor="middle">p99 latency, ms (log)</text>')
    colours = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"]
    for i, (name, reports) in enumerate(series):
        points = " ".join(f"{px(r['viewers']):.1f},{py(r['latency_ms']['p99']):.1f}" for r in reports)
        out.append(f'<polyline points="{points}" fill="none" stroke="{colours[i]}" stroke-width="2"/>')
        for r in reports:
            shape = "none" if r["stalls"] == 0 else colours[i]
            out.append(f'<circle cx="{px(r["viewers"]):.1f}" cy="{py(r["latency_ms"]["p99"]):.1f}" r="3.5" stroke="{colours[i]}" fill="{shape}"/>')
        y = top + 14 + 18 * i
        out.append(f'<line x1="{width - right + 10}" x2="{width - right + 30}" y1="{y}" y2="{y}" stroke="{colours[i]}" stroke-width="2"/>')
        out.append(f'<text x="{width - right + 36}" y="{y + 4}">{name}</text>')
    out.append(f'<text x="{width - right + 10}" y="{top + 14 + 18 * len(series) + 8}">filled: stalls</text>')
    out.append(f'<text x="{width - right + 10}" y="{top + 14 + 18 * len(series) + 24}" fill="#d33">red: 20 ms goal</text>')
    out.append("</svg>")
    Path(path).write_text("\n".join(out) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("binary", nargs="?", default="target/release/facewire")
    parser.add_argument("seconds", nargs="?", type=float, default=10)
    parser.add_argument("--chart", help="write an SVG chart of the sweeps here")
    parser.add_argument("--json", help="write every report here")
    args = parser.parse_args()
    binary, seconds = args.binary, args.seconds
    with tempfile.TemporaryDirectory() as folder:
        server, url = serve(binary, folder)
        results = {}
        try:
            load(binary, url, 10, 40, 3, "", folder)
            for algo, name, short in [("", "V (default)", "V"), ("H", "H, point_distance:k=all", "H")]:
                results[f"{short}, 50 streams"] = sweep(binary, url, f"Viewers at 50 streams, {name}", [(50, v) for v in (100, 200, 400, 600, 800, 1000, 1200, 1500, 2000)], seconds, algo, folder)
                results[f"{short}, 4 viewers a stream"] = sweep(binary, url, f"Streams at 4 viewers each, {name}", [(s, 4 * s) for s in (10, 25, 50, 100, 150, 200, 300)], seconds, algo, folder)
            results["baseline"] = baseline(binary, url, [(10, 40), (50, 200)], seconds, folder)
        finally:
            server.terminate()
            server.wait()
        if args.json:
            Path(args.json).write_text(json.dumps(results, indent=1))
        if args.chart:
            chart([(k, v) for k, v in results.items() if k != "baseline"], args.chart)


if __name__ == "__main__":
    main()
