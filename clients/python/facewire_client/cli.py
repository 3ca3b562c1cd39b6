"""The command line: ``facewire-client`` (produce, view, register, heads, batch)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any, Dict, Optional, Sequence

from .errors import FacewireError, FrameError, Refused
from .events import ServerError, StreamEnd
from .http import Client
from .producer import Producer
from .producer_frames import _frame_seq, _number, read_jsonl
from .protocol import DEFAULT_MAX_FPS, DEFAULT_MAX_MESSAGE_BYTES
from .viewer import Viewer
from .viewer_frames import ViewerFrame


def _add_server_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--url", default="http://127.0.0.1:8480",
                        help="server base URL (default: %(default)s)")
    parser.add_argument("--token", default=None,
                        help="token sent as Authorization: Bearer (producer, viewer or admin)")
    parser.add_argument("--timeout", type=float, default=30.0,
                        help="seconds to wait for an answer (default: %(default)s)")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="facewire_client.py",
        description="Talk to a facewire server: push parameter frames, watch deformed heads, "
                    "register heads. Protocol: proto/PROTOCOL.md.")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    commands.required = True

    produce = commands.add_parser(
        "produce", help="push a JSONL stream over the producer WebSocket",
        description="Send every frame of a facewire JSONL file to a stream, one message per "
                    "frame, at the frames' timestamps unless --fast; then end the stream.")
    produce.add_argument("file", help="facewire JSONL file (docs/STREAMS.md)")
    produce.add_argument("--head", required=True, help="head id")
    produce.add_argument("--stream", default="main", help="stream name (default: %(default)s)")
    produce.add_argument("--binary", action="store_true", help="send FWP2 binary frames, not JSON")
    produce.add_argument("--fwp1", action="store_true",
                         help="send the frozen FWP1 binary frames (for servers before FWP2)")
    produce.add_argument("--fast", action="store_true",
                         help="send as fast as acks and --max-fps allow, not at the timestamps")
    produce.add_argument("--speed", type=float, default=1.0, help="playback speed factor (default: 1)")
    produce.add_argument("--max-fps", type=float, default=DEFAULT_MAX_FPS,
                         help="the server's max_fps (default: %(default)s)")
    produce.add_argument("--max-message-bytes", type=int, default=DEFAULT_MAX_MESSAGE_BYTES,
                         help="the server's max_message_bytes (default: %(default)s)")
    produce.add_argument("--no-end", action="store_true", help="do not send {\"type\":\"end\"}")
    produce.add_argument("--quiet", action="store_true", help="print only refusals and the summary")
    _add_server_options(produce)

    view = commands.add_parser(
        "view", help="watch a stream and print one line per decoded frame",
        description="Connect a viewer, download the rest mesh, decode every frame and print "
                    "seq, time, label, moved vertices and latencies (or JSON lines).")
    view.add_argument("--head", required=True, help="head id")
    view.add_argument("--stream", default="main", help="stream name (default: %(default)s)")
    view.add_argument("--algo", default=None, help="algorithm spec or letter (default: the server's)")
    view.add_argument("--face", action="store_true", help="ask for per-vertex face roughness")
    view.add_argument("--format", default="fwf2", choices=("fwf2", "fwf1"),
                      help="frame layout to ask for (default: %(default)s)")
    view.add_argument("--frames", type=int, default=None, help="stop after this many frames")
    view.add_argument("--until-end", action="store_true", help="stop at the stream's end message")
    view.add_argument("--json", action="store_true", help="print JSON lines")
    view.add_argument("--positions", action="store_true",
                      help="with --json, include every vertex position (large)")
    _add_server_options(view)

    register = commands.add_parser(
        "register", help="register a head (an OBJ, or a glTF avatar) and wait until ready")
    register.add_argument("--id", required=True, help="head id: 1-64 of a-z 0-9 - _")
    head = register.add_mutually_exclusive_group(required=True)
    head.add_argument("--obj", help="OBJ file (its texture: the map_Kd image of its mtllib, beside it)")
    head.add_argument("--avatar", help=".glb, or .gltf with its .bin and images beside it (packed into one .glb)")
    fit = register.add_mutually_exclusive_group()
    fit.add_argument("--fit", help=".fit.toml file (OBJ only)")
    fit.add_argument("--landmarks", help=".landmarks.toml file, the server solves the fit (OBJ only); "
                                         "with neither, the server finds the face itself")
    register.add_argument("--producer-token", default=None, help="this head's own producer token")
    register.add_argument("--no-wait", action="store_true", help="do not wait until ready")
    _add_server_options(register)

    heads = commands.add_parser("heads", help="list registered heads")
    _add_server_options(heads)

    batch = commands.add_parser(
        "batch", help="post a whole JSONL (or .fap) stream for the server to play")
    batch.add_argument("file", help="facewire JSONL file, or an MPEG-4 .fap file")
    batch.add_argument("--head", required=True, help="head id")
    batch.add_argument("--stream", default="main", help="stream name (default: %(default)s)")
    batch.add_argument("--audio", metavar="WAV",
                       help="the stream's voice, a WAV file (16, 24 or 48 kHz), its first "
                            "sample at the first frame's t")
    _add_server_options(batch)
    return parser


def _frame_summary(frame: ViewerFrame, received_us: int, positions: bool) -> Dict[str, Any]:
    summary: Dict[str, Any] = {
        "seq": frame.seq,
        "t": frame.producer_time_s,
        "label": frame.label,
        "moved": len(frame.moved),
        "tongue_moved": None if frame.tongue is None else len(frame.tongue.moved),
        "lip_mean": frame.lip.mean,
        "lip_folds": None if frame.folds is None else {
            "turned_over_60": frame.folds.turned_over_60,
            "turned_over_90": frame.folds.turned_over_90,
            "max_dihedral_increase_deg": frame.folds.max_dihedral_increase_deg,
        },
        "server_ms": (frame.server_send_us - frame.server_receive_us) / 1000.0,
        "delivery_ms": (received_us - frame.server_send_us) / 1000.0,
    }
    if positions and frame.positions is not None:
        summary["positions"] = frame.positions
    return summary


def _run(args: argparse.Namespace) -> int:
    if args.command == "produce":
        refused = sent = 0
        with Producer(args.url, args.head, args.stream, token=args.token,
                      binary="fwp1" if args.fwp1 else args.binary, timeout=args.timeout, max_fps=args.max_fps,
                      max_message_bytes=args.max_message_bytes) as producer:
            start: Optional[float] = None
            first_t = 0.0
            for frame in read_jsonl(args.file):
                if not args.fast:
                    t = _number(_frame_seq(frame), "t", frame.get("t"))
                    if start is None:
                        start, first_t = time.monotonic(), t
                    wait = start + (t - first_t) / args.speed - time.monotonic()
                    if wait > 0:
                        time.sleep(wait)
                try:
                    ack = producer.send(frame)
                    sent += 1
                    if not args.quiet:
                        print("ack seq %d" % ack.seq)
                except Refused as e:
                    refused += 1
                    print(str(e), file=sys.stderr)
                    if e.code in ("producer_busy", "idle"):
                        return 1
                except FrameError as e:  # not sent: the encoder cannot write this frame
                    refused += 1
                    print("not sent: %s" % e, file=sys.stderr)
            if args.no_end:
                producer.ended = True  # leave the stream running
        print("%d frame(s) acknowledged, %d refused or not sent%s"
              % (sent, refused, "" if args.no_end else "; stream ended"))
        return 1 if refused else 0

    if args.command == "view":
        count = 0
        with Viewer(args.url, args.head, args.stream, algo=args.algo, face=args.face,
                    token=args.token, timeout=args.timeout,
                    frame_format=args.format) as viewer:
            snap = viewer.snapshot
            header = {"type": "snapshot", "algorithm": snap.algorithm, "vertices": snap.vertices,
                      "mm_per_unit": snap.mm_per_unit, "step": snap.step, "format": snap.format}
            print(json.dumps(header) if args.json else
                  "snapshot: head %s stream %s algorithm %s, %d vertices, step %.3g head units, "
                  "%s frames" % (snap.head, snap.stream, snap.algorithm, snap.vertices, snap.step,
                                 snap.format))
            sys.stdout.flush()
            while True:
                try:
                    event = viewer.recv(None)
                except TimeoutError:
                    continue  # an idle stream: keep waiting
                if event is None:
                    print("closed (code %s)" % viewer.close_code, file=sys.stderr)
                    return 0
                now_us = int(time.time() * 1e6)
                if isinstance(event, ViewerFrame):
                    count += 1
                    s = _frame_summary(event, now_us, args.positions)
                    print(json.dumps(s) if args.json else
                          "seq %d t %.3f label %s moved %d lip %.4f server %.2f ms delivery %.2f ms"
                          % (s["seq"], s["t"], s["label"], s["moved"], s["lip_mean"],
                             s["server_ms"], s["delivery_ms"]))
                    if args.frames is not None and count >= args.frames:
                        return 0
                elif isinstance(event, StreamEnd):
                    print(json.dumps({"type": "end", "reason": event.reason}) if args.json
                          else "end: %s" % event.reason)
                    if args.until_end:
                        return 0
                elif isinstance(event, ServerError):
                    print("error %s: %s" % (event.code, event.message), file=sys.stderr)
                sys.stdout.flush()

    client = Client(args.url, args.token, args.timeout)
    if args.command == "register":
        if args.avatar is not None:
            if args.fit is not None or args.landmarks is not None:
                raise FacewireError("register: --fit and --landmarks go with --obj; an avatar is fitted by the server")
            info = client.register_avatar_file(args.id, args.avatar, producer_token=args.producer_token)
        else:
            info = client.register_head_files(args.id, args.obj, fit_path=args.fit,
                                              landmarks_path=args.landmarks,
                                              producer_token=args.producer_token)
        if not args.no_wait:
            info = client.wait_ready(args.id, timeout=max(args.timeout, 300.0))
        print(json.dumps(info))
        return 0
    if args.command == "heads":
        for info in client.list_heads():
            print(json.dumps(info))
        return 0
    if args.command == "batch":
        with open(args.file, "rb") as f:
            body = f.read()
        print(json.dumps(client.post_batch(args.head, args.stream, body,
                                           fap=args.file.lower().endswith(".fap"),
                                           audio=args.audio)))
        return 0
    raise AssertionError(args.command)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The command line; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except (FacewireError, OSError) as e:
        print("facewire_client: error: %s" % e, file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
