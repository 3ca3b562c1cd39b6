#!/usr/bin/env python3
"""Resident memory of `facewire serve` under load: what a viewer and a stream cost, and
whether memory stays flat over a long run at the budget.

Part 1, the cost: a fresh server per point, the server's resident memory (VmRSS) sampled
each second during a `facewire load` run; the median of the second half of the run is the
point's memory. A viewer's cost is the slope between two viewer counts at 50 streams, a
stream's between two stream counts at 4 viewers each.

Part 2, the long run: 50 streams, 1,000 viewers at 30 fps for `minutes` (10 by default),
the resident memory every 30 s. Flat means the last samples are within noise of the first
ones after warm-up.

    cargo build --release && python3 benches/load_memory.py target/release/facewire [minutes]

Standard library only; Linux (/proc)."""

import json
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

CONFIG = """[limits]
max_streams_per_head = 10000
max_viewers = 100000
max_connections = 100000
"""


def resident_mib(pid):
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def serve(binary, folder):
    config = Path(folder) / "load.toml"
    config.write_text(CONFIG)
    server = subprocess.Popen(
        [binary, "serve", "--addr", "127.0.0.1:0", "--config", str(config)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    url = server.stdout.readline().strip().removeprefix("facewire listening on ").rstrip("/")
    return server, url


def run(binary, streams, viewers, seconds, every, folder):
    """A fresh server under one load: (report, [(seconds since start, MiB)], idle MiB)."""
    server, url = serve(binary, folder)
    try:
        time.sleep(0.5)
        idle = resident_mib(server.pid)
        out = Path(folder) / "load.json"
        args = [binary, "load", "--url", url, "--streams", str(streams), "--viewers", str(viewers), "--seconds", str(seconds), "--json", str(out)]
        load = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        samples, start = [], time.monotonic()
        while load.poll() is None:
            samples.append((time.monotonic() - start, resident_mib(server.pid)))
            time.sleep(every)
        if load.returncode != 0:
            raise RuntimeError(f"facewire load failed: {args}")
        return json.loads(out.read_text()), samples, idle
    finally:
        server.terminate()
        server.wait()


def steady(samples, seconds):
    """Median memory over the second half of the producing time."""
    middle = [mib for t, mib in samples if seconds / 2 <= t <= seconds]
    return statistics.median(middle)


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else "target/release/facewire"
    minutes = float(sys.argv[2]) if len(sys.argv) > 2 else 10
    with tempfile.TemporaryDirectory() as folder:
        print("| streams | viewers | idle MiB | under load MiB | p99 ms | stalls |")
        print("|---|---|---|---|---|---|")
        points = {}
        for streams, viewers in [(50, 200), (50, 1000), (10, 40), (100, 400)]:
            report, samples, idle = run(binary, streams, viewers, 20, 1, folder)
            points[(streams, viewers)] = steady(samples, 20)
            print(f"| {streams} | {viewers} | {idle:.1f} | {points[(streams, viewers)]:.1f} | {report['latency_ms']['p99']:.2f} | {report['stalls']} |", flush=True)
        per_viewer = (points[(50, 1000)] - points[(50, 200)]) / 800 * 1024
        # 90 more streams bring 360 more viewers: take their cost out.
        per_stream = ((points[(100, 400)] - points[(10, 40)]) * 1024 - 360 * per_viewer) / 90
        print(f"\nper viewer: {per_viewer:.1f} KiB; per stream (its pipeline, beyond its viewers): {per_stream:.1f} KiB")

        seconds = minutes * 60
        report, samples, idle = run(binary, 50, 1000, seconds, 30, folder)
        print(f"\n{minutes:g} minutes at 50 streams, 1,000 viewers: p99 {report['latency_ms']['p99']:.2f} ms, "
              f"stalls {report['stalls']}, received {100 * report['frames_received'] / max(report['frames_expected'], 1):.2f} %\n")
        print("| minute | resident MiB |")
        print("|---|---|")
        for t, mib in samples:
            print(f"| {t / 60:.1f} | {mib:.1f} |")
        warm = [mib for t, mib in samples if 60 <= t <= 180]
        last = [mib for t, mib in samples if seconds - 120 <= t <= seconds]
        print(f"\nminutes 1-3: median {statistics.median(warm):.1f} MiB; last 2 minutes: median {statistics.median(last):.1f} MiB")


if __name__ == "__main__":
    main()
