#!/usr/bin/env python3
"""The Python decoder against the wire fixtures (proto/fixtures/README.md).

    python3 clients/python/fixtures_test.py proto/fixtures

Every subdirectory of the given folder that holds an ``expected.json`` is a set of viewer
frames captured from a server (``fwf1/``, later ``fwf2/``): each ``.bin`` it lists is decoded
with :func:`facewire_client.decode_viewer_frame` and its digest (:func:`digest`, the
definition in proto/fixtures/README.md) must equal the listed one exactly, so the decoder
keeps reading what servers were promised to send. A ``.bin`` the file does not list is a
failure too: a fixture nothing checks protects nothing.

Then unit checks that need no server: every ``fwf1/`` frame re-encoded as ``FWF2`` by the
layout in PROTOCOL.md (its delta blocks copied byte for byte) must give the fixture's
digest, and so must the same frame as a later server might send it (:func:`future_frame`),
with its sections in another order, with a plain delta block, or with an unknown kind given
twice; malformed variants must raise ``ProtocolError`` naming the field PROTOCOL.md names (as
the Rust and JavaScript decoders name it);
``encode_fwp2`` is read back by a decoder written here from PROTOCOL.md alone; and
``encode_fwa1``, ``decode_fwa1`` and ``opus_packet_samples`` hold the cases of the Rust unit
tests in proto/src/audio_chunk.rs (the layout byte by byte, PCM and Opus round trips, the
refusals by field, a later section skipped, Opus durations), and a few more refusals.

One line per directory and per group of checks; the exit status is 1 when anything failed.
``proto/fixtures/capture.py`` imports :func:`digest` and :func:`future_frame` from here, so
the fixtures are written by the same definitions they are checked with.
"""

from __future__ import annotations

import json
import os
import struct
import sys
import zlib
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import facewire_client as fw  # noqa: E402

Moved = Sequence[Tuple[int, int, int, int]]
Sections = List[Tuple[int, bytes]]

# ---------------------------------------------------------------------------------------
# The digest (proto/fixtures/README.md, "The digest")


def moved_digest(moved: Moved) -> Dict[str, Any]:
    """Sums, absolute sums and the ends of a moved list: enough to catch any entry decoded
    wrong, without keeping thousands of entries in expected.json."""
    return {
        "count": len(moved),
        "index_sum": sum(m[0] for m in moved),
        "sum": [sum(m[k] for m in moved) for k in (1, 2, 3)],
        "abs_sum": [sum(abs(m[k]) for m in moved) for k in (1, 2, 3)],
        "first": list(moved[0]) if moved else None,
        "last": list(moved[-1]) if moved else None,
    }


def motion_digest(m: fw.RigidMotion) -> Dict[str, Any]:
    return {"rotation": list(m.rotation), "translation": list(m.translation)}


def heat_digest(frame: fw.ViewerFrame) -> Optional[Dict[str, Any]]:
    """The per-vertex values as their bytes: values are ``byte / 255 x max``, so the bytes
    come back exactly (``round(value / max x 255)``), and sums of them catch any byte
    decoded wrong. ``max`` is the one the frame carries."""
    if frame.face is None:
        return None
    top = frame.face_max if frame.face_max is not None else 0.0
    raw = [round(v / top * 255) if top > 0 else 0 for v in frame.face]
    return {"count": len(raw), "max": top, "byte_sum": sum(raw),
            "weighted_byte_sum": sum(i * b for i, b in enumerate(raw))}


def digest(frame: fw.ViewerFrame) -> Dict[str, Any]:
    """One decoded frame as proto/fixtures/README.md defines its digest; numbers as
    decoded (f32 fields widened to doubles), so equal digests mean equal decodes."""
    return {
        "seq": frame.seq,
        "t": frame.producer_time_s,
        "server_receive_us": frame.server_receive_us,
        "server_send_us": frame.server_send_us,
        "step": frame.step,
        "vertex_count": frame.vertex_count,
        "moved": moved_digest(frame.moved),
        "lip": {"min": frame.lip.min, "max": frame.lip.max, "mean": frame.lip.mean,
                "per_vertex": frame.lip.per_vertex},
        "label": frame.label,
        "head": motion_digest(frame.head),
        "jaw": motion_digest(frame.jaw),
        "folds": None if frame.folds is None else {
            "turned_over_60": frame.folds.turned_over_60,
            "turned_over_90": frame.folds.turned_over_90,
            "max_dihedral_increase_deg": frame.folds.max_dihedral_increase_deg},
        "parts": [{"part": p.part, "vertex_count": p.vertex_count,
                   "moved": moved_digest(p.moved)} for p in frame.parts],
        "heat": heat_digest(frame),
    }


def differences(got: Any, expected: Any, path: str = "") -> List[str]:
    """Where two digests differ, as ``path: got X, expected Y`` lines (exact equality)."""
    if isinstance(got, dict) and isinstance(expected, dict):
        out: List[str] = []
        for key in sorted(set(got) | set(expected)):
            where = "%s.%s" % (path, key) if path else key
            if key not in got or key not in expected:
                out.append("%s: %s" % (where, "missing" if key not in got else "not expected"))
            else:
                out.extend(differences(got[key], expected[key], where))
        return out
    if isinstance(got, list) and isinstance(expected, list) and len(got) == len(expected):
        return [d for i, (g, e) in enumerate(zip(got, expected))
                for d in differences(g, e, "%s[%d]" % (path, i))]
    if got != expected or isinstance(got, bool) != isinstance(expected, bool):
        return ["%s: got %s, expected %s"
                % (path or "digest", json.dumps(got)[:120], json.dumps(expected)[:120])]
    return []


# ---------------------------------------------------------------------------------------
# FWF2 built by hand (PROTOCOL.md, "Viewer frame (FWF2)")


def build_fwf2(header: bytes, sections: Sections) -> bytes:
    """``FWF2``, the 32 bytes of seq, t and the two times, the count, then the sections."""
    out = bytearray(b"FWF2" + header + bytes([len(sections)]))
    for kind, body in sections:
        out += struct.pack("<BI", kind, len(body)) + body
    return bytes(out)


def split_fwf2(data: bytes) -> Tuple[bytes, Sections]:
    """The header (without magic and count) and the sections of a well-formed ``FWF2``."""
    assert data[:4] == b"FWF2", data[:4]
    header, count, at = data[4:36], data[36], 37
    sections: Sections = []
    for _ in range(count):
        kind, length = struct.unpack_from("<BI", data, at)
        sections.append((kind, data[at + 5:at + 5 + length]))
        at += 5 + length
    assert at == len(data), "%d bytes after the sections" % (len(data) - at)
    return header, sections


def future_frame(data: bytes) -> bytes:
    """An ``FWF2`` frame as a later server might send it (proto/fixtures/README.md): every
    section grown by three bytes at its end (fields no decoder knows yet) and an extra
    section of kind 200 (a kind no decoder knows), the count adjusted. It must decode as
    the original does."""
    header, sections = split_fwf2(data)
    grown = [(kind, body + b"\xfa\xfb\xfc") for kind, body in sections]
    return build_fwf2(header, grown + [(200, b"later")])


def fwf1_as_fwf2(data: bytes) -> Tuple[bytes, Sections]:
    """An ``FWF1`` frame's content in ``FWF2`` sections, walked by PROTOCOL.md's FWF1 table
    (not by the client's decoder, which this checks), delta blocks copied verbatim:
    ``(header, sections in increasing kind)``."""
    flags = data[4]
    header = data[8:40]
    step, vertex_count, moved = struct.unpack_from("<fII", data, 40)
    encoding = 1 if flags & 4 else 0
    lip_end = 65 + 4 * data[64]
    at = lip_end
    sections: Sections = [(2, data[52:lip_end])]

    def take(n: int) -> bytes:
        nonlocal at
        at += n
        return data[at - n:at]

    if flags & 2:
        sections.append((3, take(1 + data[at])))
    for bit, kind in ((8, 4), (16, 5)):
        if flags & bit:
            sections.append((kind, take(28)))
    if flags & 64:
        sections.append((6, take(8)))
    (length,) = struct.unpack("<I", take(4))
    sections.append((1, struct.pack("<fIIBI", step, vertex_count, moved, encoding, length)
                     + take(length)))
    if flags & 32:
        part, part_vertices, part_moved, length = struct.unpack("<BIII", take(13))
        sections.append((7, struct.pack("<BfIIBI", part, step, part_vertices, part_moved,
                                        encoding, length) + take(length)))
    if flags & 1:
        sections.append((8, take(4) + struct.pack("<I", vertex_count) + take(vertex_count)))
    assert at == len(data), "%d bytes after the FWF1 fields" % (len(data) - at)
    return header, sorted(sections, key=lambda s: s[0])


def varint(n: int) -> bytes:
    """Unsigned LEB128."""
    out = bytearray()
    while True:
        low = n & 0x7F
        n >>= 7
        if n:
            out.append(low | 0x80)
        else:
            out.append(low)
            return bytes(out)


def with_body(sections: Sections, kind: int, change: Callable[[bytes], bytes]) -> Sections:
    """The sections with the body of every section of ``kind`` changed."""
    return [(k, change(b) if k == kind else b) for k, b in sections]


def patched(body: bytes, offset: int, fmt: str, *values: Any) -> bytes:
    """``body`` with ``values`` packed at ``offset``."""
    out = bytearray(body)
    struct.pack_into("<" + fmt, out, offset, *values)
    return bytes(out)


def plain_deltas(vertex_count: int, moved: int, block: bytes) -> bytes:
    """A deltas body with a plain (encoding 0) block written here, step 0.5."""
    return struct.pack("<fIIBI", 0.5, vertex_count, moved, 0, len(block)) + block


def plain(body: bytes, block_at: int) -> bytes:
    """A deltas or part_deltas body whose deflated block is stored plain (encoding 0)."""
    block = zlib.decompress(body[block_at + 5:], -15)
    return body[:block_at] + struct.pack("<BI", 0, len(block)) + block


class Checks:
    """Counts checks and prints each failure as it happens."""

    def __init__(self, group: str):
        self.group = group
        self.passed = 0
        self.failed = 0

    def check(self, name: str, problems: List[str]) -> None:
        if problems:
            self.failed += 1
            for problem in problems:
                print("  FAIL %s: %s: %s" % (self.group, name, problem))
        else:
            self.passed += 1

    def same_digest(self, name: str, data: bytes, expected: Dict[str, Any]) -> None:
        try:
            got = digest(fw.decode_viewer_frame(data))
        except fw.ProtocolError as e:
            self.check(name, ["ProtocolError: %s" % e])
            return
        self.check(name, differences(got, expected))

    def refused(self, name: str, data: bytes, field: str,
                decode: Callable[[bytes], Any] = fw.decode_viewer_frame) -> None:
        try:
            decode(data)
        except fw.ProtocolError as e:
            self.check(name, [] if e.field == field else
                       ["field %r, expected %r (%s)" % (e.field, field, e)])
            return
        self.check(name, ["decoded, expected a ProtocolError naming %r" % field])

    def summary(self) -> bool:
        print("%s: %d checks, %d failed" % (self.group, self.passed + self.failed, self.failed))
        return self.failed == 0


def check_fwf2(fwf1_dir: str, expected: Dict[str, Any]) -> bool:
    """decode_fwf2 on every fwf1 fixture re-encoded as FWF2, its later-server and reordered
    variants, and malformed variants of two frames (one with every section but the label,
    one with a label)."""
    c = Checks("decode_fwf2")
    for name in sorted(expected):
        with open(os.path.join(fwf1_dir, name), "rb") as f:
            header, sections = fwf1_as_fwf2(f.read())
        frame = build_fwf2(header, sections)
        c.same_digest(name + " as FWF2", frame, expected[name])
        c.same_digest(name + " from a later server", future_frame(frame), expected[name])
        c.same_digest(name + " sections reversed", build_fwf2(header, sections[::-1]),
                      expected[name])
        plain_blocks = with_body(with_body(sections, 1, lambda b: plain(b, 12)),
                                 7, lambda b: plain(b, 13))
        c.same_digest(name + " plain delta blocks", build_fwf2(header, plain_blocks),
                      expected[name])

    with open(os.path.join(fwf1_dir, "ict_motion.1.bin"), "rb") as f:
        header, full = fwf1_as_fwf2(f.read())
    assert [k for k, _ in full] == [1, 2, 4, 5, 6, 7, 8], [k for k, _ in full]
    with open(os.path.join(fwf1_dir, "ict_folds.0.bin"), "rb") as f:
        label_header, labelled = fwf1_as_fwf2(f.read())
    frame = build_fwf2(header, full)
    deltas = dict(full)[1]
    part = dict(full)[7]
    vertex_count = struct.unpack_from("<I", deltas, 4)[0]
    c.same_digest("an unknown kind twice", build_fwf2(header, full + [(99, b"a"), (99, b"bc")]),
                  expected["ict_motion.1.bin"])

    bad: List[Tuple[str, bytes, str]] = [
        ("bad magic", b"FWF3" + frame[4:], "magic"),
        ("cut in the header", frame[:30], "header"),
        ("no section count", frame[:36], "section count"),
        ("the last section past the message", frame[:-1], "section"),
        ("an unknown section past the message",
         build_fwf2(header, full + [(200, b"later")])[:-1], "section"),
        ("a section header cut",
         frame[:36] + bytes([frame[36] + 1]) + frame[37:] + b"\xc8\x01", "section"),
        ("bytes after the last section", frame + b"\x00", "end"),
        ("more sections counted than given",
         frame[:36] + bytes([frame[36] + 1]) + frame[37:], "section"),
        ("deltas shorter than its fields", build_fwf2(header, with_body(full, 1, lambda b: b[:10])),
         "moved"),
        ("a delta block past its section",
         build_fwf2(header, with_body(full, 1, lambda b: b[:-1])), "delta block"),
        ("lip_roughness shorter than its values",
         build_fwf2(header, with_body(full, 2, lambda b: b[:-4])), "lip roughness"),
        ("head_motion shorter than its fields",
         build_fwf2(header, with_body(full, 4, lambda b: b[:20])), "head motion"),
        ("lip_folds shorter than its fields",
         build_fwf2(header, with_body(full, 6, lambda b: b[:6])), "lip folds"),
        ("part_deltas cut in its block",
         build_fwf2(header, with_body(full, 7, lambda b: b[:-1])), "delta block"),
        ("part_deltas without its part", build_fwf2(header, with_body(full, 7, lambda b: b"")),
         "part"),
        ("deltas without its step", build_fwf2(header, with_body(full, 1, lambda b: b[:2])),
         "step"),
        ("heat shorter than its values",
         build_fwf2(header, with_body(full, 8, lambda b: b[:-1])), "heat"),
        ("label shorter than its length",
         build_fwf2(label_header, with_body(labelled, 3, lambda b: b[:-1])), "label"),
        ("label not UTF-8",
         build_fwf2(label_header, with_body(labelled, 3, lambda b: b"\x02\xff\xfe")), "label"),
        ("lip_roughness twice", build_fwf2(header, full + [(2, dict(full)[2])]), "lip_roughness"),
        ("head_motion twice", build_fwf2(header, full + [(4, dict(full)[4])]), "head_motion"),
        ("a part's deltas twice", build_fwf2(header, full + [(7, part)]), "part_deltas"),
        ("no deltas", build_fwf2(header, [s for s in full if s[0] != 1]), "deltas"),
        ("no lip_roughness", build_fwf2(header, [s for s in full if s[0] != 2]), "lip_roughness"),
        ("encoding 2", build_fwf2(header, with_body(full, 1, lambda b: patched(b, 12, "B", 2))),
         "encoding"),
        ("part encoding 7",
         build_fwf2(header, with_body(full, 7, lambda b: patched(b, 13, "B", 7))), "encoding"),
        ("more moved than vertices",
         build_fwf2(header, with_body(full, 1, lambda b: patched(b, 8, "I", vertex_count + 1))),
         "moved"),
        ("a part moving more than its vertices",
         build_fwf2(header, with_body(full, 7, lambda b: patched(b, 9, "I", 1 << 20))),
         "part moved"),
        ("a deflate block that is not deflate",
         build_fwf2(header, with_body(full, 1, lambda b: b[:17] + b"\xff" * (len(b) - 17))),
         "delta block"),
        ("a vertex past the head", build_fwf2(header, with_body(full, 1, lambda b: plain_deltas(
            vertex_count, 1, varint(vertex_count) + b"\x00\x00\x00"))), "index gap"),
        ("a plain block with bytes after its entries", build_fwf2(header, with_body(
            full, 1, lambda b: plain_deltas(vertex_count, 1, b"\x00" * 5))), "delta block"),
        ("a varint running off its block", build_fwf2(header, with_body(
            full, 1, lambda b: plain_deltas(vertex_count, 1, b"\x00\x00\x00\x80"))),
         "delta block"),
        ("a head rotation that is not a unit",
         build_fwf2(header, with_body(full, 4, lambda b: patched(b, 12, "f", 2.0))),
         "head motion"),
        ("a jaw translation that is not finite",
         build_fwf2(header, with_body(full, 5, lambda b: patched(b, 16, "f", float("nan")))),
         "jaw motion"),
        ("a negative dihedral increase",
         build_fwf2(header, with_body(full, 6, lambda b: patched(b, 4, "f", -1.0))), "lip folds"),
        ("heat not one value per vertex",
         build_fwf2(header, with_body(full, 8, lambda b: patched(b, 4, "I", vertex_count - 1))),
         "heat count"),
    ]
    for name, data, field in bad:
        c.refused(name, data, field)
    return c.summary()


# ---------------------------------------------------------------------------------------
# FWP2 read back (PROTOCOL.md, "Producer WebSocket")


def decode_fwp2(data: bytes) -> Dict[str, Any]:
    """A decoder of ``FWP2`` written from PROTOCOL.md's table alone, to read back what
    ``encode_fwp2`` writes: every section by kind, in the order given."""
    assert data[:4] == b"FWP2", data[:4]
    seq, t, count = struct.unpack_from("<QdB", data, 4)
    out: Dict[str, Any] = {"seq": seq, "t": t, "kinds": []}
    at = 21
    lists = {1: ("au", "<Hf"), 2: ("fap", "<Bf"), 3: ("arkit", "<Bf")}
    for _ in range(count):
        kind, length = struct.unpack_from("<BI", data, at)
        body = data[at + 5:at + 5 + length]
        assert len(body) == length, "section %d past the message" % kind
        at += 5 + length
        out["kinds"].append(kind)
        if kind in lists:
            key, fmt = lists[kind]
            (n,) = struct.unpack_from("<H", body)
            size = struct.calcsize(fmt)
            assert length == 2 + n * size, "%s: %d bytes for %d entries" % (key, length, n)
            out[key] = [struct.unpack_from(fmt, body, 2 + i * size) for i in range(n)]
        elif kind in (4, 5):
            out["head_rotation" if kind == 4 else "head_translation"] = struct.unpack("<3f", body)
        elif kind == 6:
            assert body[0] == length - 1, "label length"
            out["label"] = body[1:].decode("utf-8")
        elif kind == 7:
            assert length == 5, "viseme: %d bytes" % length
            out["viseme"] = tuple(body)
    assert at == len(data), "%d bytes after the last section" % (len(data) - at)
    return out


def f32(x: float) -> float:
    return float(struct.unpack("<f", struct.pack("<f", x))[0])


def check_fwp2() -> bool:
    """encode_fwp2 read back: every section in kind order with the frame's values, none for
    what the frame leaves out, and the same refusals as encode_fwp1 (but head_translation,
    which FWP2 carries)."""
    c = Checks("encode_fwp2")
    frame = {"seq": 7, "t": 1.25, "label": "pá",
             "au": {"jaw_drop": 0.5, "upper_lip_raiser": -0.25},
             "fap": {"raise_tongue_tip": -40, "open_jaw": 120},
             "arkit": {"tongueOut": 0.75, "jawOpen": 0.5},
             "head_rotation_rad": [0.1, -0.2, 0.05], "head_translation": [0.02, -0.01, 0.0],
             "viseme": {"oculus": "aa"}}
    got = decode_fwp2(fw.encode_fwp2(frame))
    want = {"seq": 7, "t": 1.25, "kinds": [1, 2, 3, 4, 5, 6, 7],
            "au": [(0, -0.25), (1, 0.5)], "fap": [(3, 120.0), (44, -40.0)],
            "arkit": [(17, 0.5), (51, 0.75)],
            "head_rotation": tuple(f32(x) for x in (0.1, -0.2, 0.05)),
            "head_translation": tuple(f32(x) for x in (0.02, -0.01, 0.0)),
            "label": "pá", "viseme": (1, 10, 0, 0, 0)}
    c.check("a frame with every section", differences(got, want))
    c.check("a frame with none", differences(decode_fwp2(fw.encode_fwp2({"seq": 1, "t": 0})),
                                             {"seq": 1, "t": 0.0, "kinds": []}))
    c.check("empty lists and a label give only the label", differences(
        decode_fwp2(fw.encode_fwp2({"seq": 2, "t": 0.5, "au": {}, "arkit": {}, "label": ""})),
        {"seq": 2, "t": 0.5, "kinds": [6], "label": ""}))
    long_label = decode_fwp2(fw.encode_fwp2({"seq": 3, "t": 0, "label": "é" * 200}))["label"]
    c.check("a long label cut at a character", [] if long_label == "é" * 127 else [long_label])
    for name, bad in [("controls", {"seq": 1, "t": 0, "controls": [[0, 0, 0]]}),
                      ("expression", {"seq": 1, "t": 0, "expression": {}}),
                      ("a short translation", {"seq": 1, "t": 0, "head_translation": [0, 0]}),
                      ("an infinite translation",
                       {"seq": 1, "t": 0, "head_translation": [0, float("inf"), 0]}),
                      ("no t", {"seq": 1}),
                      ("an unknown unit", {"seq": 1, "t": 0, "au": {"x": 1}})]:
        try:
            fw.encode_fwp2(bad)
            c.check(name, ["encoded, expected a FrameError"])
        except fw.FrameError:
            c.check(name, [])
    return c.summary()


# ---------------------------------------------------------------------------------------
# FWA1 (PROTOCOL.md, "Audio (FWA1)"), on the cases of proto/src/audio_chunk.rs's tests


def pcm_chunk(t_s: float, samples: List[int]) -> fw.AudioChunk:
    """A chunk of 16 kHz PCM, as a producer sends it."""
    return fw.AudioChunk(t_s, 0, "pcm", 16000, samples)


def build_fwa1(sections: Sections) -> bytes:
    """``FWA1`` at t 1 s from a producer (no receipt), then the sections given."""
    out = bytearray(b"FWA1" + struct.pack("<dQB", 1.0, 0, len(sections)))
    for kind, body in sections:
        out += struct.pack("<BI", kind, len(body)) + body
    return bytes(out)


def decoded_as(data: bytes, want: fw.AudioChunk) -> List[str]:
    """Problems with ``data`` decoding to ``want``."""
    try:
        got = fw.decode_fwa1(data)
    except fw.ProtocolError as e:
        return ["ProtocolError: %s" % e]
    return [] if got == want else ["decoded %r, expected %r" % (got, want)]


def check_fwa1() -> bool:
    """The Rust unit tests' cases (round trips with their layout, Opus durations from the
    table of contents, malformed chunks by field and a later section skipped), then more
    refusals of the decoder, and what the encoder will not write."""
    c = Checks("fwa1")
    chunk = pcm_chunk(0.25, [0, -1, 32767, -32768])
    data = fw.encode_fwa1(chunk)
    # Header 21, section 5 + rate 4 + count 4 + 8 bytes of samples.
    c.check("the pcm layout", differences(
        [len(data), list(data[:4]), list(data[21:26]), list(data[34:36])],
        [21 + 5 + 8 + 8, list(b"FWA1"), [1, 16, 0, 0, 0], [0, 0]]))
    c.check("pcm round trip", decoded_as(data, chunk) + differences(chunk.duration_s, 4 / 16000))
    # 20 ms of CELT (config 31: 20 ms, code 0: one frame).
    opus = fw.AudioChunk(0.25, 0, "opus", 48000, packet=bytes([31 << 3, 0xAA, 0xBB]))
    c.check("opus round trip", decoded_as(fw.encode_fwa1(opus), opus)
            + differences(fw.opus_packet_samples(opus.packet), 960))

    # SILK 10 ms x1, SILK 60 ms x2 (code 1), hybrid 20 ms, CELT 2.5 ms x 48 (code 3).
    # And CELT 2.5 ms x 2 with the count byte's VBR and padding bits set (not the count).
    for packet, samples in (([0], 480), ([(3 << 3) | 1], 5760), ([13 << 3], 960),
                            ([(16 << 3) | 3, 48], 5760), ([(16 << 3) | 3, 0xC2], 240)):
        try:
            problems = differences(fw.opus_packet_samples(bytes(packet)), samples)
        except fw.ProtocolError as e:
            problems = ["ProtocolError: %s" % e]
        c.check("opus duration of %r" % packet, problems)
    for packet in ([], [(16 << 3) | 3], [(16 << 3) | 3, 0], [(19 << 3) | 3, 7]):
        c.refused("opus duration of %r" % packet, bytes(packet), "opus", fw.opus_packet_samples)

    good = fw.encode_fwa1(pcm_chunk(1.0, [5] * 3))
    decode = fw.decode_fwa1
    both = bytearray(good)
    both[20] = 2
    both += bytes([2, 3, 0, 0, 0, 1, 0, 0])
    pcm_twice = bytearray(good)
    pcm_twice[20] = 2
    pcm_twice += good[21:]
    bad: List[Tuple[str, bytes, str]] = [
        ("a rate not listed", patched(good, 26, "I", 44100), "sample_rate"),
        ("more samples counted than given", patched(good, 30, "I", 4), "pcm"),
        ("a t_s not finite", patched(good, 4, "d", float("nan")), "t_s"),
        ("no section", patched(good[:21], 20, "B", 0), "sound"),
        ("pcm and opus", bytes(both), "sound"),
        ("not FWA1", b"FWP2xxxx", "magic"),
        ("pcm twice", bytes(pcm_twice), "sound"),
        ("cut in the header", good[:15], "server_receive_us"),
        ("no section count", good[:20], "section count"),
        ("a section past the message", good[:-1], "section"),
        ("a section header cut", patched(good, 20, "B", 2) + b"\x01\x00", "section"),
        ("bytes after the last section", good + b"\x00", "end"),
        ("pcm without its count", build_fwa1([(1, struct.pack("<I", 16000))]), "pcm count"),
        ("opus without its length", build_fwa1([(2, b"\x01")]), "opus length"),
        ("an opus packet cut short", build_fwa1([(2, struct.pack("<H", 3) + b"\x00")]), "opus"),
        ("an opus packet over 1275 bytes",
         build_fwa1([(2, struct.pack("<H", 1276) + bytes(1276))]), "opus"),
        ("an opus packet of 49 frames",
         build_fwa1([(2, struct.pack("<H", 2) + bytes([(16 << 3) | 3, 49]))]), "opus"),
    ]
    for name, data, field in bad:
        c.refused(name, data, field, decode)
    later = bytearray(good)
    later[20] = 2
    later += bytes([77, 1, 0, 0, 0, 9])
    c.check("a later section skipped", decoded_as(bytes(later), fw.AudioChunk(
        1.0, 0, "pcm", 16000, [5] * 3, ignored=[77])))
    c.check("a pcm section grown at its end", decoded_as(
        build_fwa1([(1, good[26:] + b"new")]), pcm_chunk(1.0, [5] * 3)))
    c.check("an opus section grown at its end", decoded_as(
        build_fwa1([(2, struct.pack("<H", 1) + b"\x00" + b"new")]),
        fw.AudioChunk(1.0, 0, "opus", 48000, packet=b"\x00")))

    for name, unwritable in [
            ("a rate not listed", fw.AudioChunk(0.0, 0, "pcm", 44100, [0])),
            ("a t_s not finite", pcm_chunk(float("inf"), [0])),
            ("a sample past 16 bits", pcm_chunk(0.0, [32768])),
            ("a sample that is not an integer", pcm_chunk(0.0, [0.5])),  # type: ignore[list-item]
            ("pcm with a packet", fw.AudioChunk(0.0, 0, "pcm", 16000, [0], packet=b"\x00")),
            ("opus not at 48 kHz", fw.AudioChunk(0.0, 0, "opus", 16000, packet=b"\x00")),
            ("an opus packet over 1275 bytes", fw.AudioChunk(0.0, 0, "opus", 48000,
                                                             packet=bytes(1276))),
            ("an empty opus packet", fw.AudioChunk(0.0, 0, "opus", 48000)),
            ("another codec", fw.AudioChunk(0.0, 0, "mp3", 16000, [0]))]:
        try:
            fw.encode_fwa1(unwritable)
            c.check("encode " + name, ["encoded, expected a FrameError"])
        except fw.FrameError:
            c.check("encode " + name, [])
    return c.summary()


# ---------------------------------------------------------------------------------------


def check_directory(directory: str) -> bool:
    """Every frame expected.json lists decodes to its digest; every .bin is listed."""
    with open(os.path.join(directory, "expected.json"), encoding="utf-8") as f:
        expected: Dict[str, Any] = json.load(f)
    name = os.path.basename(os.path.normpath(directory))
    failed = 0
    for file in sorted(expected):
        try:
            with open(os.path.join(directory, file), "rb") as f:
                problems = differences(digest(fw.decode_viewer_frame(f.read())), expected[file])
        except (OSError, fw.ProtocolError) as e:
            problems = ["%s: %s" % (type(e).__name__, e)]
        for problem in problems:
            print("  FAIL %s/%s: %s" % (name, file, problem))
        failed += bool(problems)
    unlisted = sorted(f for f in os.listdir(directory) if f.endswith(".bin") and f not in expected)
    for file in unlisted:
        print("  FAIL %s/%s: not in expected.json" % (name, file))
    print("%s: %d frames, %d match, %d differ, %d not listed"
          % (name, len(expected), len(expected) - failed, failed, len(unlisted)))
    return failed == 0 and not unlisted


def main(argv: Sequence[str]) -> int:
    if len(argv) != 1:
        print("usage: fixtures_test.py FIXTURES_DIR (proto/fixtures)", file=sys.stderr)
        return 2
    root = argv[0]
    directories = sorted(os.path.join(root, d) for d in os.listdir(root)
                         if os.path.isfile(os.path.join(root, d, "expected.json")))
    if not directories:
        print("no directory with an expected.json in %s" % root, file=sys.stderr)
        return 1
    ok = all([check_directory(d) for d in directories])
    fwf1 = os.path.join(root, "fwf1")
    with open(os.path.join(fwf1, "expected.json"), encoding="utf-8") as f:
        ok = check_fwf2(fwf1, json.load(f)) and ok
    ok = check_fwp2() and ok
    ok = check_fwa1() and ok
    print("fixtures_test: %s" % ("ok" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
