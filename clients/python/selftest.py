#!/usr/bin/env python3
"""End-to-end check of facewire_client.py against a running server.

Registers a head over HTTP, connects a viewer, pushes the frames of a JSONL file with a
producer (even-numbered frames as JSON text, odd-numbered ones as binary FWP1), repeats
one frame to provoke an ``out_of_order`` refusal, ends the stream, collects the viewer's
decoded frames until ``end``, posts the same frames as a batch, and writes everything
(acks, the refusal, seq/label/step/positions/head motion/tongue of every decoded frame, the
client's name tables) to a JSON file. It checks nothing itself beyond what the client raises:
tests/python_client.rs runs it against an in-process server and compares the decoded
positions with what the library computes.

    python3 clients/python/selftest.py --url http://127.0.0.1:PORT --head mh \\
        --obj data/heads/makehuman_head.obj --fit data/heads/makehuman_head.fit.toml \\
        --frames frames.jsonl --out result.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import threading
import time
from typing import Any, Dict, List, Optional

import facewire_client as fw


def collect(viewer: fw.Viewer, result: Dict[str, Any], timeout_s: float) -> None:
    """Reads viewer events until ``end`` (or a close, or ``timeout_s`` of silence)."""
    frames: List[Dict[str, Any]] = []
    errors: List[Dict[str, Any]] = []
    result["frames"] = frames
    result["viewer_errors"] = errors
    result["end"] = None
    try:
        while True:
            event = viewer.recv(timeout_s)
            if event is None:
                result["viewer_closed"] = viewer.close_code
                return
            if isinstance(event, fw.ViewerFrame):
                assert event.positions is not None
                frames.append({
                    "seq": event.seq,
                    "t": event.producer_time_s,
                    "label": event.label,
                    "step": event.step,
                    "vertex_count": event.vertex_count,
                    "moved": len(event.moved),
                    "lip_per_vertex": len(event.lip.per_vertex),
                    "positions": [c for p in event.positions for c in p],
                    "head_rotation": list(event.head.rotation),
                    "head_translation": list(event.head.translation),
                    "placed_first": list(event.place(event.positions[:1])[0]),
                    "tongue": None if event.tongue is None else len(event.tongue.moved),
                })
            elif isinstance(event, fw.StreamEnd):
                result["end"] = event.reason
                return
            else:
                errors.append(dataclasses.asdict(event))
    except BaseException as e:  # reported by the main thread
        result["viewer_exception"] = "%s: %s" % (type(e).__name__, e)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--url", required=True, help="server base URL, http://127.0.0.1:PORT")
    parser.add_argument("--head", required=True, help="id to register the head under")
    parser.add_argument("--obj", required=True, help="the head's OBJ file")
    parser.add_argument("--fit", required=True, help="the head's .fit.toml file")
    parser.add_argument("--frames", required=True, help="facewire JSONL file of the frames to push")
    parser.add_argument("--stream", default="selftest", help="stream name (default: %(default)s)")
    parser.add_argument("--pace-s", type=float, default=0.02,
                        help="pause between frames, seconds (default: %(default)s)")
    parser.add_argument("--out", required=True, help="JSON file to write the results to")
    args = parser.parse_args()

    client = fw.Client(args.url, timeout=30.0)
    registered = client.register_head_files(args.head, args.obj, fit_path=args.fit)
    ready = client.wait_ready(args.head, timeout=300.0)
    heads = [info["id"] for info in client.list_heads()]
    frames = list(fw.read_jsonl(args.frames))

    viewer = fw.Viewer(args.url, args.head, args.stream, timeout=30.0)
    assert viewer.rest is not None
    seen: Dict[str, Any] = {}
    reader = threading.Thread(target=collect, args=(viewer, seen, 30.0), daemon=True)
    reader.start()

    sent: List[Dict[str, Any]] = []
    refusal: Optional[Dict[str, Any]] = None
    repeat_at = len(frames) // 2
    producer = fw.Producer(args.url, args.head, args.stream, timeout=30.0)
    try:
        for i, frame in enumerate(frames):
            if i:
                time.sleep(args.pace_s)  # between frames only: `end` follows the last at once
            binary = i % 2 == 1
            ack = producer.send(frame, binary=binary)
            sent.append({"seq": frame["seq"], "binary": binary, "ack_seq": ack.seq,
                         "received_us": ack.received_us})
            if i == repeat_at:
                try:
                    producer.send(frame, binary=False)
                except fw.Refused as e:
                    refusal = {"code": e.code, "field": e.field, "seq": e.seq, "message": e.message}
        ended = producer.end()
        if ended.reason != "producer_ended":
            raise SystemExit("the server answered end with %r" % ended)
    finally:
        producer.close()
    reader.join(60.0)
    viewer.close()
    if reader.is_alive():
        raise SystemExit("the viewer thread did not finish within 60 s")

    batch = client.post_batch(args.head, args.stream + "-batch", frames)

    result: Dict[str, Any] = {
        "registered": registered,
        "ready": ready,
        "heads": heads,
        "snapshot": dataclasses.asdict(viewer.snapshot),
        "rest": {
            "vertices": len(viewer.rest.positions),
            "triangles": len(viewer.rest.triangles),
            "mm_per_unit": viewer.rest.mm_per_unit,
        },
        "sent": sent,
        "refusal": refusal,
        "batch": batch,
        "tables": {
            "animation_units": [list(names) for names in fw.ANIMATION_UNIT_NAMES],
            "faps": list(fw.FAP_NAMES),
            "arkit": list(fw.ARKIT_BLENDSHAPES),
        },
    }
    result.update(seen)
    with open(args.out, "w", encoding="utf-8") as f:
        json.dump(result, f)
    print("pushed %d frames (%d as FWP1), the viewer decoded %d, end: %r"
          % (len(sent), sum(s["binary"] for s in sent), len(seen.get("frames", [])),
             seen.get("end")))
    if "viewer_exception" in seen:
        print("viewer failed: %s" % seen["viewer_exception"], file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
