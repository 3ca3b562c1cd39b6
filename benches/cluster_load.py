#!/usr/bin/env python3
"""One node against a cluster of three, on this machine: `facewire load` against a single
`facewire serve` (bus = "local") and against three nodes sharing one NATS server
(`nats-server -js`), side by side in one run. All of them share this machine's cores with
each other, with NATS and with the load generator, so three nodes here cost three times
the deform work on the same cores: the run measures what the bus costs, not what more
machines would give (docs/PERFORMANCE.md "Cluster" does that arithmetic).

Rows:
  one node        producers and viewers on one node
  hop             producers on node 1, every viewer on node 2: each frame crosses NATS once;
                  its latency minus the one-node row's is what the hop adds
  three nodes     producers on node 1, viewers spread over nodes 1-3

    cargo build --release && python3 benches/cluster_load.py target/release/facewire \\
        [--streams 50 --viewers 1000 --seconds 20] [--json FILE]

Needs `nats-server` on PATH (or $NATS_SERVER). Standard library only."""

import argparse
import json
import os
import socket
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

LIMITS = """[limits]
max_streams_per_head = 10000
max_viewers = 100000
max_connections = 100000
"""


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_nats(folder):
    port = free_port()
    binary = os.environ.get("NATS_SERVER", "nats-server")
    proc = subprocess.Popen(
        [binary, "-js", "-a", "127.0.0.1", "-p", str(port), "-sd", str(Path(folder) / "js")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    for _ in range(200):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
            return proc, f"nats://127.0.0.1:{port}"
        except OSError:
            time.sleep(0.05)
    raise RuntimeError("nats-server did not start")


def serve(binary, folder, name, bus):
    config = Path(folder) / f"{name}.toml"
    config.write_text(f'bus = "{bus}"\nnode_name = "{name}"\n' + LIMITS)
    proc = subprocess.Popen(
        [binary, "serve", "--addr", "127.0.0.1:0", "--config", str(config),
         "--data-dir", str(Path(folder) / name)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    url = proc.stdout.readline().strip().removeprefix("facewire listening on ").rstrip("/")
    return proc, url


def hop_histogram(url):
    """(count, [(upper bound s, cumulative count)]) of facewire_bus_hop_seconds."""
    text = urllib.request.urlopen(f"{url}/metrics").read().decode()
    buckets, count = [], 0
    for line in text.splitlines():
        if line.startswith("facewire_bus_hop_seconds_bucket{"):
            le = line.split('le="')[1].split('"')[0]
            buckets.append((float("inf") if le == "+Inf" else float(le), int(float(line.split()[-1]))))
        elif line.startswith("facewire_bus_hop_seconds_count"):
            count = int(float(line.split()[-1]))
    return count, buckets


def quantile_bound(count, buckets, q):
    """The upper bound of the histogram bucket holding quantile `q`."""
    for bound, cumulative in buckets:
        if cumulative >= q * count:
            return bound
    return float("nan")


def load(binary, url, view_urls, args, folder, label):
    out = Path(folder) / f"{label}.json"
    command = [binary, "load", "--url", url, "--streams", str(args.streams),
               "--viewers", str(args.viewers), "--seconds", str(args.seconds), "--json", str(out)]
    for view in view_urls:
        command += ["--view-url", view]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.loads(out.read_text())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("binary")
    parser.add_argument("--streams", type=int, default=50)
    parser.add_argument("--viewers", type=int, default=1000)
    parser.add_argument("--seconds", type=float, default=20)
    parser.add_argument("--json")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        single, single_url = serve(args.binary, folder, "single", "local")
        try:
            rows.append(("one node", load(args.binary, single_url, [], args, folder, "single"), None))
        finally:
            single.terminate()
            single.wait()
        nats, bus = start_nats(folder)
        nodes = [serve(args.binary, folder, f"n{i}", bus) for i in (1, 2, 3)]
        urls = [url for _, url in nodes]
        try:
            hop = load(args.binary, urls[0], [urls[1]], args, folder, "hop")
            rows.append(("hop (produce n1, view n2)", hop, hop_histogram(urls[1])))
            spread = load(args.binary, urls[0], urls, args, folder, "three")
            rows.append(("three nodes", spread, None))
        finally:
            for proc, _ in nodes:
                proc.terminate()
                proc.wait()
            nats.terminate()
            nats.wait()

    print(f"{args.streams} streams x {args.viewers} viewers, {args.seconds:g} s, 30 fps; "
          "nodes, NATS and generator share this machine's cores")
    print("| setup | received % | stalls | p50 ms | p99 ms | max ms | server CPU % (sum) | server MiB (sum) |")
    print("|---|---|---|---|---|---|---|---|")
    for label, r, _ in rows:
        received = 100 * r["frames_received"] / max(1, r["frames_expected"])
        server = r.get("server") or {}
        print(f"| {label} | {received:.1f} | {r['stalls']} | {r['latency_ms']['p50']:.2f} | "
              f"{r['latency_ms']['p99']:.2f} | {r['latency_ms']['max']:.1f} | "
              f"{server.get('cpu_percent', float('nan')):.0f} | {server.get('resident_mib_after', float('nan')):.0f} |")
    one, hop = rows[0][1], rows[1][1]
    count, buckets = rows[1][2]
    print(f"NATS hop, from the generator: p50 +{hop['latency_ms']['p50'] - one['latency_ms']['p50']:.2f} ms, "
          f"p99 +{hop['latency_ms']['p99'] - one['latency_ms']['p99']:.2f} ms over one node")
    print(f"NATS hop, node 2's bus histogram ({count} frames): p50 <= {1e3 * quantile_bound(count, buckets, 0.5):.2f} ms, "
          f"p99 <= {1e3 * quantile_bound(count, buckets, 0.99):.2f} ms")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": [{"setup": l, "report": r} for l, r, _ in rows],
                                               "bus_histogram": {"count": count, "buckets": buckets}},
                                              indent=1))


if __name__ == "__main__":
    main()
