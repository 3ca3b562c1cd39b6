#!/usr/bin/env python3
"""Load sweeps for docs/PERFORMANCE.md: `facewire serve` with raised limits and
`facewire load` against it, on this machine, printing one Markdown table per sweep.

    python3 benches/load_sweep.py target/release/facewire [seconds]

Sweeps: viewers at 50 streams, and streams at 4 viewers each, for the default algorithm
and for H (`point_distance:k=all`, the slowest preset on the MakeHuman head). A short
warm-up run comes first; a sweep stops after two points in a row past the knee (p99 over
20 ms or any stall), since one point alone can be an outlier on a shared machine."""

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


def load(binary, url, streams, viewers, seconds, algo, folder):
    out = Path(folder) / "load.json"
    args = [binary, "load", "--url", url, "--streams", str(streams), "--viewers", str(viewers), "--seconds", str(seconds), "--json", str(out)]
    if algo:
        args += ["--algo", algo]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.loads(out.read_text())


def row(r):
    received = 100.0 * r["frames_received"] / max(r["frames_expected"], 1)
    lat = r["latency_ms"]
    server = r["server"] or {}
    return (
        f"| {r['streams']} | {r['viewers']} | {received:.1f} % | {r['stalls']} | {lat['p50']:.2f} | "
        f"{lat['p99']:.2f} | {lat['max']:.1f} | {server.get('cpu_percent', float('nan')):.0f} | "
        f"{server.get('resident_mib_after', float('nan')):.1f} |"
    )


def sweep(binary, url, title, points, seconds, algo, folder):
    print(f"\n{title}\n")
    print("| streams | viewers | received | stalls | p50 ms | p99 ms | max ms | server CPU % of a core | server MiB |")
    print("|---|---|---|---|---|---|---|---|---|")
    past_knee = 0
    for streams, viewers in points:
        r = load(binary, url, streams, viewers, seconds, algo, folder)
        print(row(r), flush=True)
        past_knee = past_knee + 1 if r["latency_ms"]["p99"] > 20.0 or r["stalls"] > 0 else 0
        if past_knee == 2:
            break
        time.sleep(1)


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else "target/release/facewire"
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 10
    with tempfile.TemporaryDirectory() as folder:
        server, url = serve(binary, folder)
        try:
            load(binary, url, 10, 40, 3, "", folder)
            for algo, name in [("", "default algorithm (U)"), ("H", "H, point_distance:k=all")]:
                sweep(binary, url, f"Viewers at 50 streams, {name}", [(50, v) for v in (100, 200, 400, 600, 800, 1000)], seconds, algo, folder)
                sweep(binary, url, f"Streams at 4 viewers each, {name}", [(s, 4 * s) for s in (10, 25, 50, 100, 150, 200)], seconds, algo, folder)
        finally:
            server.terminate()
            server.wait()


if __name__ == "__main__":
    main()
