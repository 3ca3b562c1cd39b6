#!/usr/bin/env python3
"""Resident memory of `facewire serve` while thousands of streams and hundreds of algorithm
bindings come and go: memory must return to its working size when clients leave.

A fresh server (at most 4 streams a head, streams linger 50 ms, at most 2 bindings a head)
with the MakeHuman head. Each round opens one viewer per new stream name, reads its
snapshot and closes it; one viewer in ten asks for another algorithm
(`point_distance:k=2..101`, each bound, then evicted), the others for the default. A
viewer refused for room (`limit_reached`) tries again until the streams before it have
lingered out. After each round and a pause of 1.5 s (retired pipelines' memory is given
back at most once a second), the server's resident memory (VmRSS). The first round
reaches the allocator's and the blocking pool's working size; later rounds must not grow
past it (the service's budget: memory returns to its baseline when clients leave).

    cargo build --release && python3 benches/stream_churn_memory.py target/release/facewire [names per round] [rounds]

websocket-client (the Python client's one dependency, which .ci/run installs); Linux
(/proc)."""

import json
import os
import subprocess
import sys
import tempfile
import time
import urllib.request

import websocket

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIG = """default_algorithm = "U"
[limits]
max_streams_per_head = 4
stream_linger_s = 0.05
max_bindings_per_head = 2
"""


def resident_kib(pid):
    for line in open("/proc/%d/status" % pid):
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS for %d" % pid)


def register(url):
    body = json.dumps({
        "id": "mh",
        "obj": open(os.path.join(ROOT, "data/heads/makehuman_head.obj")).read(),
        "fit": open(os.path.join(ROOT, "data/heads/makehuman_head.fit.toml")).read(),
    }).encode()
    urllib.request.urlopen(urllib.request.Request(
        url + "/v1/heads", data=body, headers={"Content-Type": "application/json"})).read()
    while json.load(urllib.request.urlopen(url + "/v1/heads/mh"))["status"] != "ready":
        time.sleep(0.05)


def churn(ws_url, names):
    """One viewer per stream name in `names`; returns how many were refused for room first."""
    refused = 0
    for i in names:
        algo = "point_distance:k=%d" % (2 + (i // 10) % 100) if i % 10 == 0 else ""
        for _ in range(1000):
            viewer = websocket.create_connection(
                "%s/v1/heads/mh/streams/n%d/view?algo=%s" % (ws_url, i, algo), timeout=30)
            first = json.loads(viewer.recv())
            if first.get("type") == "snapshot":
                break
            viewer.close()
            if first.get("code") != "limit_reached":
                raise RuntimeError("viewer %d: %s" % (i, first))
            refused += 1
            time.sleep(0.01)
        else:
            raise RuntimeError("viewer %d: no room after 1,000 tries" % i)
        viewer.close()
    return refused


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/facewire")
    per_round = int(sys.argv[2]) if len(sys.argv) > 2 else 2000
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    with tempfile.TemporaryDirectory() as folder:
        config = os.path.join(folder, "churn.toml")
        with open(config, "w") as f:
            f.write(CONFIG)
        data = os.path.join(folder, "data")
        server = subprocess.Popen([binary, "serve", "--addr", "127.0.0.1:0", "--config", config,
                                   "--data-dir", data],
                                  stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            url = server.stdout.readline().strip().replace("facewire listening on ", "").rstrip("/")
            register(url)
            ws_url = url.replace("http://", "ws://")
            rows = [("registered", resident_kib(server.pid), 0, 0.0)]
            for r in range(rounds):
                started = time.time()
                refused = churn(ws_url, range(r * per_round, (r + 1) * per_round))
                took = time.time() - started
                time.sleep(1.5)
                rows.append(("after %d names" % ((r + 1) * per_round), resident_kib(server.pid), refused, took))
            info = json.load(urllib.request.urlopen(url + "/v1/heads/mh"))
        finally:
            server.terminate()
            server.wait()
    print("%-20s %10s %14s %8s" % ("", "RSS KiB", "waited (tries)", "s"))
    for name, kib, refused, took in rows:
        print("%-20s %10d %14d %8.1f" % (name, kib, refused, took))
    grown = rows[-1][1] - rows[1][1]
    print("after the first round: %+d KiB over %d more names (%.2f KiB a name); "
          "streams left %d, algorithms bound %d"
          % (grown, per_round * (rounds - 1), grown / max(1, per_round * (rounds - 1)),
             len(info.get("streams", [])), len(info.get("algorithms", []))))


if __name__ == "__main__":
    main()
