#!/usr/bin/env python3
"""What one registration upload can make `facewire serve` do: the table in
docs/PERFORMANCE.md ("What one upload can make a node do").

Starts the given facewire binary on a free port with a temporary data directory, then
posts, one at a time, heads built to be expensive (the ICT head scaled by 1e11; 2,000 of
its vertices joined by 250,000 or 2.5 million random triangles; five of the 250,000 at
once; the ICT head subdivided twice with 360 and with 165 random triangles added) for the
automatic fit, and prints each answer, its time and the server's resident memory (VmRSS)
and its peak (VmHWM), in MB. Standard library only; takes about a minute.

    cargo build --release && python3 benches/bounded_uploads.py target/release/facewire
"""

import json
import os
import random
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ICT = os.path.join(ROOT, "data", "heads", "ict_head.obj")


def read(path):
    vertices, triangles = [], []
    for line in open(path):
        parts = line.split()
        if parts and parts[0] == "v":
            vertices.append(tuple(map(float, parts[1:4])))
        elif parts and parts[0] == "f":
            corners = [int(c.split("/")[0]) - 1 for c in parts[1:]]
            triangles += [(corners[0], corners[k], corners[k + 1]) for k in range(1, len(corners) - 1)]
    return vertices, triangles


def obj(vertices, triangles):
    lines = ["v %r %r %r" % tuple(v) for v in vertices]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in triangles]
    return "\n".join(lines) + "\n"


def subdivided(vertices, triangles):
    vertices, middle, out = list(vertices), {}, []

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in middle:
            middle[key] = len(vertices)
            vertices.append(tuple((x + y) / 2 for x, y in zip(vertices[a], vertices[b])))
        return middle[key]

    for a, b, c in triangles:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    return vertices, out


def spanning(vertices, count, rng):
    return [tuple(rng.randrange(len(vertices)) for _ in range(3)) for _ in range(count)]


def memory_mb(pid):
    fields = {}
    for line in open(f"/proc/{pid}/status"):
        if line.startswith(("VmRSS", "VmHWM")):
            name, kb = line.split(":")
            fields[name] = int(kb.split()[0]) / 1000
    return fields


def post(url, body):
    started = time.time()
    request = urllib.request.Request(url + "/v1/heads", data=json.dumps(body).encode(),
                                     headers={"content-type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=300) as response:
            status, text = response.status, response.read().decode()
    except urllib.error.HTTPError as error:
        status, text = error.code, error.read().decode()
    return status, text, time.time() - started


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"http://127.0.0.1:{port}"
    rng = random.Random(1)
    ict = read(ICT)
    dense = subdivided(*subdivided(*ict))
    few = rng.sample(ict[0], 2000)
    cases = [
        ("ICT head scaled by 1e11", [[c * 1e11 for c in v] for v in ict[0]], ict[1]),
        ("2,000 vertices, 250,000 spanning triangles", few, spanning(few, 250_000, rng)),
        ("2,000 vertices, 2.5 million spanning triangles", few, spanning(few, 2_500_000, rng)),
        ("ICT subdivided twice + 360 spanning", dense[0], dense[1] + spanning(dense[0], 360, rng)),
        ("ICT subdivided twice + 165 spanning", dense[0], dense[1] + spanning(dense[0], 165, rng)),
    ]
    with tempfile.TemporaryDirectory() as data:
        server = subprocess.Popen([sys.argv[1], "serve", "--addr", f"127.0.0.1:{port}", "--data-dir", data],
                                  stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        server.stdout.readline()
        try:
            for k, (what, vertices, triangles) in enumerate(cases):
                status, text, seconds = post(url, {"id": f"case{k}", "obj": obj(vertices, triangles)})
                print(f"{what}: {status} in {seconds:.2f} s, {memory_mb(server.pid)}: {text[:160]}")
            body = {"obj": obj(few, spanning(few, 250_000, rng))}
            answers = []
            threads = [threading.Thread(target=lambda k=k: answers.append(post(url, dict(body, id=f"c{k}"))))
                       for k in range(5)]
            started = time.time()
            for thread in threads:
                thread.start()
            for thread in threads:
                thread.join()
            print(f"five 250,000-triangle uploads at once: {[a[0] for a in answers]} in "
                  f"{time.time() - started:.2f} s, {memory_mb(server.pid)}")
        finally:
            server.terminate()
            server.wait()


if __name__ == "__main__":
    main()
