#!/usr/bin/env python3
"""Viewers that never read, one per algorithm, heat map and format of one stream: what they
make `facewire serve` do (docs/PERFORMANCE.md, "Viewers that never read").

Starts the given facewire binary on a free port with a temporary data directory, registers
the MakeHuman head with its fit, opens 48 viewer sockets on one stream (16 algorithm
presets x heat none / roughness / folds, formats cycling fwf1 / fwf2 / json), then 9 more
on a second stream with one of those algorithms (every heat x format), never reads them
past their first message, produces 10 s of frames at 30 fps into both streams,
and prints how many viewers were taken and how many refused (and with what error code),
the server's threads, its resident memory and /healthz's latency while it works.
Needs websocket-client (`pip install websocket-client`); takes about 30 s.

    cargo build --release && python3 benches/idle_viewers.py target/release/facewire
"""

import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

import websocket

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HEAD = os.path.join(ROOT, "data", "heads", "makehuman_head")
PRESETS = "ABCDEFGHIJKLMNOP"
HEATS = ["none", "roughness", "folds"]
FORMATS = ["fwf1", "fwf2", "json"]
PRODUCE_S = 10.0


def status(pid):
    fields = {}
    for line in open(f"/proc/{pid}/status"):
        name, _, value = line.partition(":")
        if name in ("Threads", "VmRSS", "VmHWM"):
            fields[name] = int(value.split()[0])
    return fields


def get(url, timeout=10):
    with urllib.request.urlopen(url, timeout=timeout) as response:
        return response.status, response.read()


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"http://127.0.0.1:{port}"
    ws = f"ws://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory() as data:
        server = subprocess.Popen([sys.argv[1], "serve", "--addr", f"127.0.0.1:{port}", "--data-dir", data],
                                  stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        server.stdout.readline()
        try:
            body = {"id": "mh", "obj": open(HEAD + ".obj").read(), "fit": open(HEAD + ".fit.toml").read()}
            request = urllib.request.Request(url + "/v1/heads", data=json.dumps(body).encode(),
                                             headers={"content-type": "application/json"})
            urllib.request.urlopen(request, timeout=60).read()
            while json.loads(get(url + "/v1/heads/mh")[1]).get("status") != "ready":
                time.sleep(0.1)
            before = status(server.pid)
            taken = []

            def watch(stream, queries):
                refused = {}
                for query in queries:
                    viewer = websocket.create_connection(f"{ws}/v1/heads/mh/streams/{stream}/view?{query}",
                                                         timeout=10)
                    first = json.loads(viewer.recv())
                    if first["type"] == "error":
                        refused[first["code"]] = refused.get(first["code"], 0) + 1
                        viewer.close()
                    else:
                        taken.append(viewer)
                return refused

            refused = watch("talk", [f"algo={PRESETS[k % 16]}&heat={HEATS[k // 16]}&format={FORMATS[k % 3]}"
                                     for k in range(48)])
            taken_first = len(taken)
            # One algorithm the head binds already, every heat map and format: 9 pipelines
            # asked of a second stream.
            refused_keys = watch("talk2", [f"algo=A&heat={heat}&format={fmt}" for heat in HEATS for fmt in FORMATS])
            producers = [websocket.create_connection(f"{ws}/v1/heads/mh/streams/{stream}/produce", timeout=10)
                         for stream in ("talk", "talk2")]
            started, seq, health_ms, peak_threads = time.time(), 0, [], 0
            while time.time() - started < PRODUCE_S:
                t = seq / 30.0
                jaw = 0.3 * (1 + ((seq // 10) % 2))
                for producer in producers:
                    producer.send(json.dumps({"seq": seq, "t": t, "au": {"jaw_drop": jaw}}))
                seq += 1
                if seq % 15 == 0:
                    asked = time.time()
                    get(url + "/healthz")
                    health_ms.append((time.time() - asked) * 1e3)
                    peak_threads = max(peak_threads, status(server.pid)["Threads"])
                time.sleep(max(0.0, started + seq / 30.0 - time.time()))
            during = status(server.pid)
            print(f"one per algorithm, heat and format: {taken_first} of 48 viewers taken; refused: "
                  + ", ".join(f"{n} with {code}" for code, n in sorted(refused.items())))
            print(f"one algorithm, every heat and format, on a second stream: {len(taken) - taken_first} of 9 taken; refused: "
                  + ", ".join(f"{n} with {code}" for code, n in sorted(refused_keys.items())))
            print(f"threads: {before['Threads']} before, {peak_threads} at most while producing")
            print(f"resident memory: {before['VmRSS'] / 1000:.0f} MB before, {during['VmRSS'] / 1000:.0f} MB "
                  f"after {seq} frames (peak {during['VmHWM'] / 1000:.0f} MB)")
            print(f"/healthz while producing: median {statistics.median(health_ms):.1f} ms, "
                  f"max {max(health_ms):.1f} ms over {len(health_ms)} requests")
            for producer in producers:
                producer.close()
            for viewer in taken:
                viewer.close()
        finally:
            server.kill()
            server.wait()


if __name__ == "__main__":
    main()
