#!/usr/bin/env python3
"""Resident memory of `facewire serve` around one head's registration and deletion.

Subdivides the shipped scan (8,838 vertices) twice into a 141,378-vertex head (10 MB of
OBJ), then, against a fresh server with a temporary data directory, registers it twice,
deleting it after each registration, and prints the resident memory (VmRSS) and its peak
(VmHWM) at each point, in MiB. Standard library only.

    cargo build --release && python3 benches/registration_memory.py target/release/facewire
"""

import json
import os
import subprocess
import sys
import tempfile
import time
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def subdivided(path, times):
    """OBJ text of the mesh at `path` with every triangle split in four, `times` times."""
    vertices, faces = [], []
    for line in open(path):
        parts = line.split()
        if parts and parts[0] == "v":
            vertices.append(tuple(map(float, parts[1:4])))
        elif parts and parts[0] == "f":
            faces.append(tuple(int(p.split("/")[0]) - 1 for p in parts[1:4]))
    for _ in range(times):
        middle = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                middle[key] = len(vertices)
                vertices.append(tuple((vertices[a][i] + vertices[b][i]) / 2 for i in range(3)))
            return middle[key]

        split = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            split += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        faces = split
    lines = ["v %.6f %.6f %.6f" % v for v in vertices]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in faces]
    return "\n".join(lines) + "\n", len(vertices)


def memory(pid):
    values = {}
    for line in open("/proc/%d/status" % pid):
        key, value = line.split(":", 1)
        if key in ("VmRSS", "VmHWM"):
            values[key] = int(value.split()[0]) // 1024
    return values


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/facewire")
    obj, count = subdivided(os.path.join(ROOT, "data/heads/lee_perry_smith_head.obj"), 2)
    fit = open(os.path.join(ROOT, "data/heads/lee_perry_smith_head.fit.toml")).read()
    body = json.dumps({"id": "big", "obj": obj, "fit": fit}).encode()
    with tempfile.TemporaryDirectory() as data:
        server = subprocess.Popen([binary, "serve", "--addr", "127.0.0.1:0", "--data-dir", data],
                                  stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            url = server.stdout.readline().strip().replace("facewire listening on ", "").rstrip("/")
            rows = [("start", memory(server.pid))]
            for cycle in (1, 2):
                started = time.time()
                urllib.request.urlopen(urllib.request.Request(
                    url + "/v1/heads", data=body, headers={"Content-Type": "application/json"})).read()
                while json.load(urllib.request.urlopen(url + "/v1/heads/big"))["status"] == "registering":
                    time.sleep(0.1)
                rows.append(("registered %d (%.1f s)" % (cycle, time.time() - started), memory(server.pid)))
                urllib.request.urlopen(urllib.request.Request(url + "/v1/heads/big", method="DELETE")).read()
                time.sleep(2.0)
                rows.append(("deleted %d" % cycle, memory(server.pid)))
        finally:
            server.terminate()
            server.wait()
    print("head: %d vertices, %.1f MB of OBJ" % (count, len(obj) / 1e6))
    print("%-24s %10s %10s" % ("", "RSS MiB", "peak MiB"))
    for name, values in rows:
        print("%-24s %10d %10d" % (name, values["VmRSS"], values["VmHWM"]))


if __name__ == "__main__":
    main()
