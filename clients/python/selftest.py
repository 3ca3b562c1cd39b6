#!/usr/bin/env python3
"""End-to-end check of the facewire_client package against a running server.

Registers a head over HTTP, connects two viewers (one asking for FWF2 frames, the
default, and for PCM audio, one for the frozen FWF1 and no audio), pushes the frames of a
JSONL file with a producer (even-numbered frames as JSON text, odd-numbered ones as binary,
alternately FWP2 and the frozen FWP1; the first FWP2 frame carries an extra section of kind
99, which no server knows), repeats one frame to provoke an ``out_of_order`` refusal, ends
the stream, collects both viewers' decoded frames until ``end``, posts the same frames as a
batch, and writes everything (acks, the refusal, seq/label/step/positions/head motion/tongue
of every frame the FWF2 viewer decoded, the client's name tables, the audio sent and heard)
to a JSON file.

Alongside the first frames the producer sends the stream's voice, 20 ms chunks of 16 kHz
PCM (:func:`send_audio_along`): from integers, from bytes, a call cut into two chunks, a
WAV file, and one chunk overlapping the one before it, sent just before a parameter frame,
so that the server's refusal of it arrives ahead of that frame's ack. The frame must still
get its own ack, and the refusal must come out of the next audio call as ``AudioRefused``.

Then the asyncio interface (:mod:`facewire_client.aio`) plays ten frames with their voice
to a viewer of its own (:func:`asyncio_round`), and a ``.gltf`` written as separate files is
packed into one ``.glb`` (:func:`gltf_packing`).

tests/service/python_client.rs installs the package (``pip install ./clients/python``) and runs
this script with the installed one against an in-process server and compares the decoded
positions with what the library computes. What needs no library to check, this script
checks itself, and exits 1 naming what failed: the snapshots announce the layouts and the
audio asked for, the ack of the frame with kind 99 says ``"ignored": [99]`` and no other
ack ignores anything, every frame both viewers got decodes the same from FWF2 as from FWF1,
the audio viewer heard every accepted chunk and nothing else, in order and byte for byte
(stamped with the server's receipt), the other viewer heard none, and the overlapping chunk
was refused as ``out_of_order`` (field ``t``) by the next audio call.

    python3 clients/python/selftest.py --url http://127.0.0.1:PORT --head mh \\
        --obj data/heads/makehuman_head.obj --fit data/heads/makehuman_head.fit.toml \\
        --frames frames.jsonl --out result.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import struct
import sys
import tempfile
import threading
import time
import wave
import zlib
from typing import Any, Dict, List, Optional, Tuple

import asyncio

import facewire_client as fw
from facewire_client import aio


def collect(viewer: fw.Viewer, result: Dict[str, Any], timeout_s: float) -> None:
    """Reads viewer events until ``end`` (or a close, or ``timeout_s`` of silence)."""
    frames: List[Dict[str, Any]] = []
    errors: List[Dict[str, Any]] = []
    audio: List[Dict[str, Any]] = []
    result["frames"] = frames
    result["viewer_errors"] = errors
    result["audio"] = audio
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
            elif isinstance(event, fw.AudioChunk):  # PCM, as asked: no packet to keep
                audio.append({k: v for k, v in dataclasses.asdict(event).items() if k != "packet"})
            elif isinstance(event, fw.StreamEnd):
                result["end"] = event.reason
                return
            else:
                errors.append(dataclasses.asdict(event))
    except BaseException as e:  # reported by the main thread
        result["viewer_exception"] = "%s: %s" % (type(e).__name__, e)


def with_unknown_section(fwp2: bytes) -> bytes:
    """An FWP2 message with a section of kind 99 appended (its count raised): what a
    producer newer than the server might send. The server must skip it and say so."""
    count = fwp2[20]
    return fwp2[:20] + bytes([count + 1]) + fwp2[21:] + struct.pack("<BI", 99, 3) + b"new"


#: The audio's sample rate, and the samples in one of the producer's 20 ms chunks.
RATE = 16000
CHUNK = 320


def pcm(tag: int, count: int) -> List[int]:
    """``count`` samples that differ from one call (``tag``) to the next and reach both
    ends of 16 bits, so that a sample decoded wrong or out of order shows."""
    return [32767 if i == 1 else -32768 if i == 2 else (tag * 7919 + i * 263) % 65536 - 32768
            for i in range(count)]


def write_wav(path: str, samples: List[int], channels: int = 1) -> None:
    """A 16-bit WAV at :data:`RATE` (each sample repeated on every channel)."""
    with wave.open(path, "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes(struct.pack("<%dh" % (len(samples) * channels),
                                  *[x for x in samples for _ in range(channels)]))


def send_audio_along(producer: fw.Producer, i: int, t: float, wav_dir: str,
                     audio: Dict[str, Any]) -> float:
    """The audio sent after frame ``i`` (the first six), starting at stream time ``t``;
    returns where the next starts. Every call the server should accept goes to
    ``audio["calls"]`` as ``(t, samples)``; what an audio call raised goes to
    ``audio["refused"]``, ``audio["wav_refused"]``."""
    calls: List[Tuple[float, List[int]]] = audio["calls"]
    if i == 0:
        block = pcm(i, CHUNK)
        calls.append((t, block))
        return producer.send_audio(t, block, RATE)
    if i == 1:  # the same as little-endian bytes
        block = pcm(i, CHUNK)
        calls.append((t, block))
        return producer.send_audio(t, struct.pack("<%dh" % len(block), *block), RATE)
    if i == 2:  # 40 ms, which goes as two chunks
        block = pcm(i, 2 * CHUNK)
        calls.append((t, block))
        return producer.send_audio(t, block, RATE)
    if i == 3:  # then half a chunk back: refused, the answer on its way as frame 4 goes
        block = pcm(i, CHUNK)
        calls.append((t, block))
        end = producer.send_audio(t, block, RATE)
        producer.send_audio(end - 0.01, pcm(99, CHUNK), RATE)
        return end
    if i == 4:  # frame 4's ack came after the refusal: this call raises it, sending nothing
        block = pcm(i, CHUNK)
        try:
            producer.send_audio(t, block, RATE)
        except fw.AudioRefused as e:
            audio["refused"] = {"code": e.code, "field": e.field, "seq": e.seq,
                                "count": len(e.refusals), "message": e.message}
        calls.append((t, block))
        return producer.send_audio(t, block, RATE)
    # i == 5: a WAV file, 62.5 ms (three chunks and a short one), at its own pace; a
    # stereo one is refused before anything is sent.
    block = pcm(i, 1000)
    mono, stereo = os.path.join(wav_dir, "mono.wav"), os.path.join(wav_dir, "stereo.wav")
    write_wav(mono, block)
    write_wav(stereo, block, channels=2)
    try:
        producer.send_wav(stereo, t_s=t)
    except fw.FrameError as e:
        audio["wav_refused"] = str(e)
    calls.append((t, block))
    return producer.send_wav(mono, t_s=t)


def expected_audio(calls: List[Tuple[float, List[int]]]) -> List[bytes]:
    """Every chunk the accepted calls send, encoded as a producer sends it: each call cut
    into 20 ms chunks at ``t + i / rate`` (:meth:`Producer.send_audio`)."""
    return [fw.encode_fwa1(fw.AudioChunk(t + i / RATE, 0, "pcm", RATE, block[i:i + CHUNK]))
            for t, block in calls for i in range(0, len(block), CHUNK)]


def check_audio(viewer: fw.Viewer, viewer_fwf1: fw.Viewer, audio: Dict[str, Any],
                seen: Dict[str, Any], seen_fwf1: Dict[str, Any]) -> List[str]:
    """The audio: announced to the viewer that asked for it only, heard by it as sent
    (but for the server's receipt) and in order, the overlapping chunk refused by name."""
    problems: List[str] = []
    if viewer.snapshot.audio != "pcm" or "audio" not in viewer.snapshot.messages:
        problems.append("asked for pcm audio, the snapshot announces %r with messages %r"
                        % (viewer.snapshot.audio, viewer.snapshot.messages))
    if viewer_fwf1.snapshot.audio is not None or "audio" in viewer_fwf1.snapshot.messages:
        problems.append("asked for no audio, the snapshot announces %r with messages %r"
                        % (viewer_fwf1.snapshot.audio, viewer_fwf1.snapshot.messages))
    want = expected_audio(audio["calls"])
    heard = [fw.AudioChunk(**chunk) for chunk in seen.get("audio", [])]
    got = [fw.encode_fwa1(dataclasses.replace(chunk, server_receive_us=0, ignored=[]))
           for chunk in heard]
    if got != want:
        first = next((k for k, (g, w) in enumerate(zip(got, want)) if g != w),
                     min(len(got), len(want)))
        problems.append("the audio viewer heard %d chunks, %d were sent and accepted; the "
                        "first to differ is number %d" % (len(got), len(want), first))
    for chunk in heard:
        if chunk.server_receive_us < 1_700_000_000_000_000 or chunk.ignored:
            problems.append("chunk at t %s: server_receive_us %d, ignored %r"
                            % (chunk.t_s, chunk.server_receive_us, chunk.ignored))
    if seen_fwf1.get("audio"):
        problems.append("the viewer that asked for no audio heard %d chunks"
                        % len(seen_fwf1["audio"]))
    refused = audio.get("refused")
    if refused is None:
        problems.append("the chunk overlapping the one before it was not refused by the next "
                        "audio call")
    elif (refused["code"], refused["field"], refused["seq"], refused["count"]) \
            != ("out_of_order", "t", None, 1):
        problems.append("the overlapping chunk: expected one out_of_order refusal of field t, "
                        "got %r" % refused)
    if "wav_refused" not in audio:
        problems.append("send_wav sent a stereo file")
    return problems


def check(viewer: fw.Viewer, viewer_fwf1: fw.Viewer, sent: List[Dict[str, Any]],
          seen: Dict[str, Any], seen_fwf1: Dict[str, Any]) -> List[str]:
    """What this script can hold without the library: the layouts, the acks' ``ignored``,
    and FWF2 and FWF1 decoding to the same content."""
    problems: List[str] = []
    for name, got in (("FWF2", seen), ("FWF1", seen_fwf1)):
        if "viewer_exception" in got:
            problems.append("the %s viewer failed: %s" % (name, got["viewer_exception"]))
    if viewer.snapshot.format != "fwf2" or viewer_fwf1.snapshot.format != "fwf1":
        problems.append("asked for fwf2 and fwf1, the snapshots announce %r and %r"
                        % (viewer.snapshot.format, viewer_fwf1.snapshot.format))
    kinds = {s.kind for s in viewer.snapshot.sections}
    if not {1, 2} <= kinds:
        problems.append("the fwf2 snapshot's sections lack deltas (1) or lip_roughness (2): "
                        "%r" % viewer.snapshot.sections)
    for s in sent:
        want = [99] if s["unknown_section"] else []
        if s["ignored"] != want:
            problems.append("seq %d (%s): the ack ignores %r, expected %r"
                            % (s["seq"], s["layout"], s["ignored"], want))
    fwf1_frames = {f["seq"]: f for f in seen_fwf1.get("frames", [])}
    both = [f for f in seen.get("frames", []) if f["seq"] in fwf1_frames]
    if not both:
        problems.append("no frame reached both viewers (the last before end must)")
    for f in both:
        other = fwf1_frames[f["seq"]]
        differ = sorted(k for k in f if f[k] != other.get(k))
        if differ:
            problems.append("seq %d decodes differently from FWF2 and FWF1: %s"
                            % (f["seq"], ", ".join(differ)))
    if seen_fwf1.get("end") != seen.get("end"):
        problems.append("the viewers ended with %r (FWF2) and %r (FWF1)"
                        % (seen.get("end"), seen_fwf1.get("end")))
    return problems


async def asyncio_round(url: str, head: str, stream: str,
                        frames: List[Dict[str, Any]]) -> Tuple[Dict[str, Any], List[str]]:
    """The asyncio interface: an :class:`aio.AsyncViewer` asking for PCM watches while an
    :class:`aio.AsyncProducer` plays ``frames`` with their voice (``play(audio=...)``,
    samples spanning the frames), then ends the stream. Returns what was seen and the
    problems found: every frame acknowledged, the last frame and ``end`` seen, and every
    audio chunk heard, in order and sample for sample."""
    problems: List[str] = []
    span_s = frames[-1]["t"] - frames[0]["t"] + 1 / 30
    voice = pcm(11, int(span_s * RATE))
    async with await aio.AsyncViewer.connect(url, head, stream, timeout=30.0, audio="pcm") as viewer:

        async def watch() -> Dict[str, Any]:
            seen: Dict[str, Any] = {"seqs": [], "samples": [], "chunk_times": [], "end": None}
            async for event in viewer:
                if isinstance(event, fw.ViewerFrame):
                    seen["seqs"].append(event.seq)
                elif isinstance(event, fw.AudioChunk):
                    seen["samples"].extend(event.samples)
                    seen["chunk_times"].append(event.t_s)
                elif isinstance(event, fw.StreamEnd):
                    seen["end"] = event.reason
                    return seen
            return seen

        watching = asyncio.ensure_future(watch())
        async with await aio.AsyncProducer.connect(url, head, stream, timeout=30.0) as producer:
            acks = await producer.play(frames, audio=voice, sample_rate=RATE)
        seen = await asyncio.wait_for(watching, 30.0)
    if [a.seq for a in acks] != [f["seq"] for f in frames]:
        problems.append("asyncio: acks %r for frames %r" % ([a.seq for a in acks], [f["seq"] for f in frames]))
    if not seen["seqs"] or seen["seqs"][-1] != frames[-1]["seq"]:
        problems.append("asyncio: the viewer's last frame is %r, not %r" % (seen["seqs"][-1:], frames[-1]["seq"]))
    if seen["end"] != "producer_ended":
        problems.append("asyncio: the viewer's end was %r" % seen["end"])
    if seen["samples"] != voice:
        problems.append("asyncio: heard %d samples of the %d played, or not the same"
                        % (len(seen["samples"]), len(voice)))
    expected_times = [frames[0]["t"] + i / RATE for i in range(0, len(voice), CHUNK)]
    if any(abs(a - b) > 1e-9 for a, b in zip(seen["chunk_times"], expected_times)):
        problems.append("asyncio: chunk times %r, expected %r" % (seen["chunk_times"][:4], expected_times[:4]))
    return {"acks": len(acks), "frames_seen": len(seen["seqs"]), "samples_heard": len(seen["samples"]),
            "samples_played": len(voice), "end": seen["end"]}, problems


def batch_with_voice(client: fw.Client, url: str, head: str, stream: str,
                     frames: List[Dict[str, Any]]) -> Tuple[Dict[str, Any], List[str]]:
    """An HTTP batch with its voice (``post_batch(audio=...)``, samples from half a second
    after the first frame) while a PCM viewer listens: the answer and every sample heard,
    at its time. Returns the answer and the problems found."""
    problems: List[str] = []
    voice = pcm(23, 5 * CHUNK)
    start = frames[0]["t"] + 0.5
    heard: List[int] = []
    times: List[float] = []
    end = None
    with fw.Viewer(url, head, stream, timeout=30.0, audio="pcm") as viewer:
        answer = client.post_batch(head, stream, frames, audio=voice, sample_rate=RATE,
                                   audio_t_s=start)
        for event in viewer:
            if isinstance(event, fw.AudioChunk):
                heard.extend(event.samples)
                times.append(event.t_s)
            elif isinstance(event, fw.StreamEnd):
                end = event.reason
                break
    if heard != voice:
        problems.append("voiced batch: heard %d of %d samples, or not the same" % (len(heard), len(voice)))
    expected = [start + i * CHUNK / RATE for i in range(5)]
    if any(abs(a - b) > 1e-9 for a, b in zip(times, expected)) or len(times) != 5:
        problems.append("voiced batch: chunk times %r, expected %r" % (times, expected))
    if end != "batch_finished":
        problems.append("voiced batch: the viewer's end was %r" % end)
    return answer, problems


def derived_face(url: str, head: str, stream: str) -> List[str]:
    """A producer of audio alone (``derive="visemes"``, told each derived frame): half a
    second of sound gives the frames of half a second at 25 fps, in order on the audio's
    clock, and a parameter frame is refused by name. Returns the problems found."""
    problems: List[str] = []
    with fw.Producer(url, head, stream, timeout=30.0, derive="visemes", fps=25, derived=True) as producer:
        producer.send_audio(3.0, [(i * 37) % 4000 - 2000 for i in range(RATE // 2)], RATE)
        try:
            producer.send({"seq": 0, "t": 3.0, "au": {"jaw_drop": 0.2}})
            problems.append("derived: a parameter frame was accepted")
        except fw.Refused as e:
            if (e.code, e.field) != ("bad_frame", "derive"):
                problems.append("derived: the parameter frame was refused as %s/%s" % (e.code, e.field))
        producer.end()
        derived = producer.derived
    if not 12 <= len(derived) <= 14:
        problems.append("derived: %d frames for 0.5 s at 25 fps" % len(derived))
    for k, frame in enumerate(derived):
        if frame.seq != k or abs(frame.t - (3.0 + k / 25)) > 1e-9 or not 0 <= frame.confidence <= 1:
            problems.append("derived: frame %d is %r" % (k, frame))
            break
    return problems


def solid_png(width: int, height: int, rgb: Tuple[int, int, int]) -> bytes:
    """A PNG of one colour."""
    raw = b"".join(b"\x00" + bytes(rgb) * width for _ in range(height))

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def textured_from_files(client: fw.Client, head: str, obj_path: str, fit_path: str) -> Dict[str, Any]:
    """Registers `obj_path` again as `head`, written with a texture coordinate per vertex,
    a material library naming a texture (with an option before its file name, as modelling
    tools write them) and the PNG beside it: what register_head_files sends and the server
    serves back."""
    with open(obj_path, "r", encoding="utf-8") as f:
        lines = f.read().splitlines()
    vertices = [line for line in lines if line.startswith("v ")]
    folder = tempfile.mkdtemp(prefix="facewire-texture-")
    png = solid_png(8, 4, (30, 210, 50))
    try:
        with open(os.path.join(folder, "head.obj"), "w", encoding="utf-8") as f:
            f.write("mtllib head.mtl\n")
            f.writelines(line + "\n" for line in lines if not line.startswith("f "))
            for i in range(len(vertices)):
                f.write("vt %f 0.5\n" % (i / max(1, len(vertices) - 1)))
            for line in lines:
                if line.startswith("f "):
                    f.write("f " + " ".join("%s/%s" % (c, c) for c in line.split()[1:]) + "\n")
        with open(os.path.join(folder, "head.mtl"), "w", encoding="utf-8") as f:
            f.write("newmtl skin\nKd 1 1 1\nmap_Kd -s 1 1 1 skin.png\n")
        with open(os.path.join(folder, "skin.png"), "wb") as f:
            f.write(png)
        client.register_head_files(head, os.path.join(folder, "head.obj"), fit_path=fit_path)
        client.wait_ready(head, timeout=300.0)
        _, served = client.request("GET", "/v1/heads/%s/texture" % head)
        _, uv = client.request("GET", "/v1/heads/%s/uv.bin" % head)
    finally:
        for name in os.listdir(folder):
            os.remove(os.path.join(folder, name))
        os.rmdir(folder)
    coords, triangles = struct.unpack_from("<II", uv, 4)
    return {"texture_served_as_sent": served == png, "uv_magic": uv[:4].decode("ascii"),
            "uv_coordinates": coords, "uv_triangles": triangles}


def gltf_packing() -> List[str]:
    """An avatar as "glTF Separate" writes it (a ``.gltf``, its buffer in a ``.bin`` named
    with a space, its image under ``textures/``, a second buffer as a ``data:`` URI) packed
    by :func:`facewire_client.avatar_file` into one ``.glb``: one buffer, each view moved
    by where its buffer went (4-byte aligned), the image inside with its MIME type, no URI
    left; a ``.glb`` with everything inside is sent as it is. Problems, named."""
    problems: List[str] = []
    folder = tempfile.mkdtemp(prefix="facewire-gltf-")
    png = solid_png(2, 2, (1, 2, 3))
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "mesh%20data.bin", "byteLength": 6},
                    {"uri": "data:application/octet-stream;base64,CQoL", "byteLength": 3}],
        "bufferViews": [{"buffer": 0, "byteOffset": 2, "byteLength": 4}, {"buffer": 1, "byteLength": 3}],
        "images": [{"uri": "textures/face.png"}],
    }
    try:
        os.mkdir(os.path.join(folder, "textures"))
        with open(os.path.join(folder, "textures", "face.png"), "wb") as f:
            f.write(png)
        with open(os.path.join(folder, "mesh data.bin"), "wb") as f:
            f.write(bytes([1, 2, 3, 4, 5, 6]))
        with open(os.path.join(folder, "avatar.gltf"), "w", encoding="utf-8") as f:
            json.dump(doc, f)
        packed, binary = fw.read_glb(fw.avatar_file(os.path.join(folder, "avatar.gltf")))
        whole = fw.pack_glb({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 4}]}, b"\x07" * 4, {})
        with open(os.path.join(folder, "whole.glb"), "wb") as f:
            f.write(whole)
        if fw.avatar_file(os.path.join(folder, "whole.glb")) != whole:
            problems.append("gltf: a .glb with everything inside was not sent as it is")
    finally:
        for root, dirs, names in os.walk(folder, topdown=False):
            for name in names:
                os.remove(os.path.join(root, name))
            for name in dirs:
                os.rmdir(os.path.join(root, name))
        os.rmdir(folder)
    assert binary is not None

    def view(i: int) -> bytes:
        v = packed["bufferViews"][i]
        return binary[v["byteOffset"]:v["byteOffset"] + v["byteLength"]]

    expected = [
        ("one buffer", packed["buffers"], [{"byteLength": 12 + len(png)}]),
        ("the first view", view(0), bytes([3, 4, 5, 6])),
        ("the data: buffer's view, aligned", (packed["bufferViews"][1]["byteOffset"], view(1)), (8, bytes([9, 10, 11]))),
        ("the image inside", view(2), png),
        ("the image's view and type", packed["images"], [{"bufferView": 2, "mimeType": "image/png"}]),
        ("no URI left", "uri" in json.dumps(packed), False),
    ]
    problems += ["gltf: %s: %r != %r" % (what, got, want) for what, got, want in expected if got != want]
    return problems


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

    viewer = fw.Viewer(args.url, args.head, args.stream, timeout=30.0, audio="pcm")
    assert viewer.rest is not None
    viewer_fwf1 = fw.Viewer(args.url, args.head, args.stream, timeout=30.0, frame_format="fwf1")
    seen: Dict[str, Any] = {}
    seen_fwf1: Dict[str, Any] = {}
    readers = [threading.Thread(target=collect, args=(v, into, 30.0), daemon=True)
               for v, into in ((viewer, seen), (viewer_fwf1, seen_fwf1))]
    for reader in readers:
        reader.start()

    sent: List[Dict[str, Any]] = []
    refusal: Optional[Dict[str, Any]] = None
    repeat_at = len(frames) // 2
    audio: Dict[str, Any] = {"calls": []}
    audio_t = frames[0]["t"]
    wav_dir = tempfile.mkdtemp(prefix="facewire-selftest-")
    producer = fw.Producer(args.url, args.head, args.stream, timeout=30.0)
    try:
        for i, frame in enumerate(frames):
            if i:
                time.sleep(args.pace_s)  # between frames only: `end` follows the last at once
            binary = i % 2 == 1
            layout = ("fwp2" if i % 4 == 1 else "fwp1") if binary else "json"
            if i == 1:
                ack = producer.send_encoded(with_unknown_section(fw.encode_fwp2(frame)),
                                            frame["seq"])
            else:
                ack = producer.send(frame, binary=layout if binary else False)
            sent.append({"seq": frame["seq"], "binary": binary, "layout": layout,
                         "unknown_section": i == 1, "ack_seq": ack.seq,
                         "received_us": ack.received_us, "ignored": ack.ignored})
            if i == repeat_at:
                try:
                    producer.send(frame, binary=False)
                except fw.Refused as e:
                    refusal = {"code": e.code, "field": e.field, "seq": e.seq, "message": e.message}
            if i < 6:
                audio_t = send_audio_along(producer, i, audio_t, wav_dir, audio)
        ended = producer.end()
        if ended.reason != "producer_ended":
            raise SystemExit("the server answered end with %r" % ended)
        producer.check_audio()  # nothing refused since the overlapping chunk
    finally:
        producer.close()
        for name in os.listdir(wav_dir):
            os.remove(os.path.join(wav_dir, name))
        os.rmdir(wav_dir)
    for reader in readers:
        reader.join(60.0)
    viewer.close()
    viewer_fwf1.close()
    if any(reader.is_alive() for reader in readers):
        raise SystemExit("a viewer thread did not finish within 60 s")

    batch = client.post_batch(args.head, args.stream + "-batch", frames)
    voiced_batch, voiced_problems = batch_with_voice(client, args.url, args.head,
                                                     args.stream + "-voiced", frames[:6])
    derived_problems = derived_face(args.url, args.head, args.stream + "-derived")
    textured = textured_from_files(client, args.head + "-textured", args.obj, args.fit)
    asyncio_seen, asyncio_problems = asyncio.run(
        asyncio_round(args.url, args.head, args.stream + "-asyncio", frames[:10]))

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
        "audio_sent": {"chunks": len(expected_audio(audio["calls"])),
                       "refused": audio.get("refused"), "wav_refused": audio.get("wav_refused")},
        "batch": batch,
        "voiced_batch": voiced_batch,
        "module": fw.__file__,
        "asyncio": asyncio_seen,
        "textured": textured,
        "tables": {
            "animation_units": [list(names) for names in fw.ANIMATION_UNIT_NAMES],
            "faps": list(fw.FAP_NAMES),
            "arkit": list(fw.ARKIT_BLENDSHAPES),
        },
    }
    result.update(seen)
    problems = (check(viewer, viewer_fwf1, sent, seen, seen_fwf1)
                + check_audio(viewer, viewer_fwf1, audio, seen, seen_fwf1) + asyncio_problems
                + voiced_problems + derived_problems + gltf_packing())
    result["problems"] = problems
    with open(args.out, "w", encoding="utf-8") as f:
        json.dump(result, f)
    print("pushed %d frames (%d as FWP2, %d as FWP1), the FWF2 viewer decoded %d, the FWF1 "
          "viewer %d, end: %r"
          % (len(sent), sum(s["layout"] == "fwp2" for s in sent),
             sum(s["layout"] == "fwp1" for s in sent), len(seen.get("frames", [])),
             len(seen_fwf1.get("frames", [])), seen.get("end")))
    print("sent %d audio chunks and one refused (%s), the audio viewer heard %d, the other "
          "viewer %d" % (result["audio_sent"]["chunks"], (audio.get("refused") or {}).get("code"),
                         len(seen.get("audio", [])), len(seen_fwf1.get("audio", []))))
    print("asyncio: %(acks)d frames acknowledged, %(frames_seen)d seen, %(samples_heard)d of "
          "%(samples_played)d samples heard, end %(end)r" % asyncio_seen)
    for problem in problems:
        print("selftest: %s" % problem, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
