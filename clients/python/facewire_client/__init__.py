#!/usr/bin/env python3
"""A Python client for facewire's wire protocol, v1 (``proto/PROTOCOL.md``).

The standard library plus ``websocket-client`` (imported as ``websocket``), which only the
two WebSocket classes need; ``pip install ./clients/python`` installs both. Typed
(``py.typed``); :mod:`facewire_client.aio` gives the same producer and viewer to asyncio:

- :class:`Producer` pushes parameter frames (facewire's JSONL objects, ``docs/STREAMS.md``)
  to ``/v1/heads/{id}/streams/{stream}/produce`` as JSON text or binary ``FWP2`` (or the
  frozen ``FWP1``), reads the server's answer to each (an :class:`Ack`, with the section
  kinds the server ignored) and raises :class:`Refused` (code, field, seq) on a refusal. It
  also sends the stream's voice as ``FWA1`` audio chunks (16-bit PCM, or Opus packets), from
  samples or a WAV file, and raises :class:`AudioRefused` for chunks the server refused.
- :class:`Viewer` watches ``/v1/heads/{id}/streams/{stream}/view``: it reads the snapshot,
  downloads the rest mesh (``FWM1``) and decodes every frame, sectioned ``FWF2`` (asked
  for by default) or the frozen ``FWF1``, into seq, time, label, lip roughness and folds
  and per-vertex positions (plain lists, no numpy), the head's and the jaw's motion and the
  parts' (the tongue's) deltas; it places the head's parts (teeth, gums, tongue) for a
  frame; ``end`` and ``error`` messages come out as :class:`StreamEnd` and
  :class:`ServerError` events, and, for a viewer that asks for audio, the stream's audio
  chunks as :class:`AudioChunk` events between the frames.
- :class:`Client` wraps the HTTP resources: register a head, wait until it is ready, list
  heads, download the rest mesh and the parts' meshes, post a batch.

The binary formats have pure functions of their own (:func:`encode_fwp2`,
:func:`encode_fwp1`, :func:`decode_viewer_frame` with :func:`decode_fwf2` and
:func:`decode_fwf1`, :func:`decode_mesh`, :func:`encode_fwa1` and :func:`decode_fwa1` with
:func:`opus_packet_samples`). Nothing is kept in globals: every connection is
an object the caller owns.

Run ``facewire-client --help`` (or ``python3 -m facewire_client --help``) for the command
line (produce, view, register, heads, batch).
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import struct
import sys
import time
import urllib.error
import urllib.parse
import urllib.request
import wave
import zlib
from array import array
from dataclasses import dataclass, field
from typing import (Any, Dict, Iterable, Iterator, List, Mapping, Optional, Sequence, Tuple, Union,
                    cast)

__all__ = [
    "ANIMATION_UNITS",
    "ANIMATION_UNIT_NAMES",
    "ARKIT_BLENDSHAPES",
    "FAP_NAMES",
    "Ack",
    "AudioChunk",
    "AudioRefused",
    "Client",
    "Derived",
    "ConnectionClosed",
    "FacewireError",
    "FrameError",
    "HttpError",
    "LipFolds",
    "LipRoughness",
    "PartDeltas",
    "PartInfo",
    "Producer",
    "ProtocolError",
    "Refused",
    "RestMesh",
    "SectionInfo",
    "ServerError",
    "Snapshot",
    "StreamEnd",
    "Viewer",
    "ViewerFrame",
    "animation_unit_index",
    "arkit_index",
    "decode_fwa1",
    "decode_fwf1",
    "decode_fwf2",
    "decode_mesh",
    "decode_viewer_frame",
    "encode_fwa1",
    "encode_fwp1",
    "encode_fwp2",
    "encode_json",
    "fap_number",
    "opus_packet_samples",
    "read_jsonl",
]

PROTOCOL_VERSION = "v1"
#: The server's default ``max_message_bytes``: a producer message may be at most this long.
DEFAULT_MAX_MESSAGE_BYTES = 64 * 1024
#: The server's default ``max_fps``: frames per second a producer may send on average.
DEFAULT_MAX_FPS = 240.0
#: The sample rates a PCM audio chunk may have, Hz (PROTOCOL.md, "Audio (FWA1)").
PCM_RATES: Tuple[int, ...] = (16000, 24000, 48000)
#: Opus packets are timed (and decoded) at 48 kHz.
OPUS_RATE = 48000
#: The length of the chunks :meth:`Producer.send_audio` and :meth:`Producer.send_wav` cut
#: PCM into, seconds: what WebRTC sends, well inside the server's 200 ms per chunk.
AUDIO_CHUNK_S = 0.02

# ---------------------------------------------------------------------------------------
# Names: CANDIDE-3 animation units, MPEG-4 FAPs, ARKit blendshapes (docs/STREAMS.md).
# The Rust test tests/service/python_client.rs checks these tables against the library.

#: MPEG-4 FAP names, FAP n at index n - 1 (``src/mask/fap.rs``).
FAP_NAMES: Tuple[str, ...] = (
    "viseme", "expression", "open_jaw", "lower_t_midlip", "raise_b_midlip",
    "stretch_l_cornerlip", "stretch_r_cornerlip", "lower_t_lip_lm", "lower_t_lip_rm",
    "raise_b_lip_lm", "raise_b_lip_rm", "raise_l_cornerlip", "raise_r_cornerlip",
    "thrust_jaw", "shift_jaw", "push_b_lip", "push_t_lip", "depress_chin",
    "close_t_l_eyelid", "close_t_r_eyelid", "close_b_l_eyelid", "close_b_r_eyelid",
    "yaw_l_eyeball", "yaw_r_eyeball", "pitch_l_eyeball", "pitch_r_eyeball",
    "thrust_l_eyeball", "thrust_r_eyeball", "dilate_l_pupil", "dilate_r_pupil",
    "raise_l_i_eyebrow", "raise_r_i_eyebrow", "raise_l_m_eyebrow", "raise_r_m_eyebrow",
    "raise_l_o_eyebrow", "raise_r_o_eyebrow", "squeeze_l_eyebrow", "squeeze_r_eyebrow",
    "puff_l_cheek", "puff_r_cheek", "lift_l_cheek", "lift_r_cheek", "shift_tongue_tip",
    "raise_tongue_tip", "thrust_tongue_tip", "raise_tongue", "tongue_roll", "head_pitch",
    "head_yaw", "head_roll", "lower_t_midlip_o", "raise_b_midlip_o",
    "stretch_l_cornerlip_o", "stretch_r_cornerlip_o", "lower_t_lip_lm_o",
    "lower_t_lip_rm_o", "raise_b_lip_lm_o", "raise_b_lip_rm_o", "raise_l_cornerlip_o",
    "raise_r_cornerlip_o", "stretch_l_nose", "stretch_r_nose", "raise_nose", "bend_nose",
    "raise_l_ear", "raise_r_ear", "pull_l_ear", "pull_r_ear",
)

#: The 52 ARKit blendshapes in Apple's order; a name's index is what ``FWP2`` and ``FWP1`` carry.
ARKIT_BLENDSHAPES: Tuple[str, ...] = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
    "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
    "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
    "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker",
    "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft",
    "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
    "mouthShrugUpper", "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft",
    "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight", "browDownLeft",
    "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight", "cheekPuff",
    "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
)

# CANDIDE-3.1.6's animation units in file order: 11 AUVs, then the 54 FAPs it implements.
_AUV_UNITS: Tuple[Tuple[str, int], ...] = (
    ("upper_lip_raiser", 0), ("jaw_drop", 11), ("lip_stretcher", 2), ("brow_lowerer", 3),
    ("lip_corner_depressor", 14), ("outer_brow_raiser", 5), ("eyes_closed", 6),
    ("lid_tightener", 7), ("nose_wrinkler", 8), ("lip_presser", 9), ("upper_lid_raiser", 10),
)
_FAP_UNITS: Tuple[int, ...] = tuple(range(3, 43)) + tuple(range(51, 65))

#: Every name each CANDIDE-3 animation unit answers to, its key first, by unit index
#: (``jaw_drop``, ``auv11``; ``fap3_open_jaw``, ``fap3``, ``open_jaw``).
ANIMATION_UNIT_NAMES: Tuple[Tuple[str, ...], ...] = tuple(
    [(key, "auv%d" % auv) for key, auv in _AUV_UNITS]
    + [("fap%d_%s" % (n, FAP_NAMES[n - 1]), "fap%d" % n, FAP_NAMES[n - 1]) for n in _FAP_UNITS]
)
#: The unit keys by index: what the unit index of ``FWP2`` and ``FWP1`` points at.
ANIMATION_UNITS: Tuple[str, ...] = tuple(names[0] for names in ANIMATION_UNIT_NAMES)

# The keys a JSONL frame object may have, and those FWP1 cannot carry (FWP2 carries
# head_translation too).
_FRAME_KEYS = ("seq", "t", "label", "au", "fap", "arkit", "head_rotation_rad",
               "head_translation", "controls", "viseme", "expression")
_JSON_ONLY_KEYS = ("head_translation", "controls", "expression")
#: Oculus/Meta's viseme names, in their (and MPEG-4's) order.
OCULUS_VISEMES: Tuple[str, ...] = ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR",
                                   "aa", "E", "ih", "oh", "ou")

_U64_MAX = (1 << 64) - 1


# ---------------------------------------------------------------------------------------
# Errors


class FacewireError(Exception):
    """Base class of every error this module raises."""


class FrameError(FacewireError, ValueError):
    """A frame that cannot be sent as given (checked before anything goes on the wire)."""


class ProtocolError(FacewireError):
    """The server sent something this client cannot read (a malformed binary message, an
    unexpected message type). ``field`` and ``at`` name the field and byte when known."""

    def __init__(self, message: str, field: Optional[str] = None, at: Optional[int] = None):
        where = ""
        if field is not None:
            where = "%s: " % field if at is None else "byte %d: %s: " % (at, field)
        super().__init__(where + message)
        self.field = field
        self.at = at


class HttpError(FacewireError):
    """An HTTP error response: ``{"error": code, "message": ...}`` with its status."""

    def __init__(self, method: str, url: str, status: int, code: str, message: str):
        super().__init__("%s %s: HTTP %d %s: %s" % (method, url, status, code, message))
        self.method = method
        self.url = url
        self.status = status
        self.code = code
        self.message = message


class Refused(FacewireError):
    """The server refused a frame or a connection with an ``error`` message.

    ``code`` is the machine code (``bad_frame``, ``out_of_order``, ``rate_limited``,
    ``message_too_large``, ``producer_busy``, ``idle``, ``unknown_head``, ...); ``seq`` and
    ``field`` say which frame and field when the server knows them. After a refused frame
    the stream keeps running: the producer may send the next one."""

    def __init__(self, code: str, message: str, seq: Optional[int] = None,
                 field: Optional[str] = None):
        parts = ["refused: %s" % code]
        if seq is not None:
            parts.append("seq %d" % seq)
        if field is not None:
            parts.append("field %s" % field)
        super().__init__("%s: %s" % (", ".join(parts), message))
        self.code = code
        self.message = message
        self.seq = seq
        self.field = field


class AudioRefused(Refused):
    """The server refused one or more of the audio chunks a :class:`Producer` sent.

    Accepted chunks get no answer, so a refusal arrives whenever the server got to the
    chunk, and names no chunk: ``seq`` is None, and ``code`` (``bad_frame``,
    ``out_of_order``, ``rate_limited``), ``field`` and ``message`` are the first refusal's;
    the message usually gives the chunk's ``t``. ``refusals`` lists every refusal read
    since the last :class:`AudioRefused` was raised, oldest first (a rate or codec that does
    not fit the stream refuses every chunk after it too). :class:`Producer` says when it
    raises one."""

    def __init__(self, refusals: Sequence[Refused]):
        first = refusals[0]
        super().__init__(first.code, first.message, None, first.field)
        self.refusals = list(refusals)
        more = "" if len(refusals) == 1 else " (and %d more audio refusals)" % (len(refusals) - 1)
        self.args = ("audio %s%s" % (self.args[0], more),)


class ConnectionClosed(FacewireError):
    """The WebSocket closed. ``code`` is the close code (1001 server shutting down, 4408
    idle producer, 4409 another producer / registration failed, 4404 unknown head, ...)."""

    def __init__(self, code: Optional[int], reason: str = ""):
        text = "connection closed"
        if code is not None:
            text += " with code %d" % code
        if reason:
            text += ": %s" % reason
        super().__init__(text)
        self.code = code
        self.reason = reason


def _websocket_module() -> Any:
    """Imports websocket-client, or says how to install it."""
    try:
        import websocket  # type: ignore[import-not-found, unused-ignore]
    except ImportError as e:
        raise FacewireError(
            "facewire_client needs the websocket-client package for producers and viewers: "
            "pip install websocket-client (%s)" % e
        ) from None
    if not hasattr(websocket, "create_connection"):
        raise FacewireError(
            "the module named `websocket` at %s is not websocket-client; "
            "pip uninstall websocket && pip install websocket-client"
            % getattr(websocket, "__file__", "?")
        )
    return websocket


# ---------------------------------------------------------------------------------------
# Name resolution (case-insensitive, as the server's JSONL reader does)


def _index_text(key: str) -> Optional[int]:
    text = key.strip()
    if text.isascii() and text.isdigit():
        return int(text)
    return None


def animation_unit_index(key: Union[str, int]) -> int:
    """The CANDIDE-3 animation unit index of ``key``: an index (``1`` or ``"1"``), a unit
    key (``jaw_drop``, ``fap3_open_jaw``) or an alias (``auv11``, ``fap3``, ``open_jaw``)."""
    count = len(ANIMATION_UNIT_NAMES)
    index = key if isinstance(key, int) and not isinstance(key, bool) else None
    if isinstance(key, str):
        index = _index_text(key)
        if index is None:
            lower = key.strip().lower()
            for i, names in enumerate(ANIMATION_UNIT_NAMES):
                if lower in names:
                    return i
    if index is not None and 0 <= index < count:
        return index
    raise FrameError("unknown animation unit %r; valid: an index 0..%d or one of %s"
                     % (key, count, ", ".join(ANIMATION_UNITS)))


def fap_number(key: Union[str, int]) -> int:
    """The FAP number of ``key``: a number 3..68 (``3`` or ``"3"``), a standard name
    (``open_jaw``), ``fap3`` or ``fap3_open_jaw``. FAPs 1 and 2 (viseme, expression) are
    not values: JSONL frames give them as ``viseme`` / ``expression``."""
    number: Optional[int] = None
    if isinstance(key, int) and not isinstance(key, bool):
        number = key
    elif isinstance(key, str):
        lower = key.strip().lower()
        number = _index_text(lower)
        if number is None and lower.startswith("fap"):
            rest = lower[3:]
            digits = len(rest) - len(rest.lstrip("0123456789"))
            if digits and 1 <= int(rest[:digits]) <= len(FAP_NAMES):
                n = int(rest[:digits])
                name = rest[digits:]
                if name == "" or name == "_" + FAP_NAMES[n - 1]:
                    number = n
        elif number is None and lower in FAP_NAMES:
            number = FAP_NAMES.index(lower) + 1
    if number is not None and 3 <= number <= len(FAP_NAMES):
        return number
    raise FrameError("unknown FAP %r; valid: a FAP number 3..=68 or a name: %s"
                     % (key, ", ".join(FAP_NAMES[2:])))


def arkit_index(key: Union[str, int]) -> int:
    """The ARKit blendshape index of ``key``: a name (``jawOpen``, any case) or 0..51."""
    index: Optional[int] = None
    if isinstance(key, int) and not isinstance(key, bool):
        index = key
    elif isinstance(key, str):
        index = _index_text(key)
        if index is None:
            lower = key.strip().lower()
            for i, name in enumerate(ARKIT_BLENDSHAPES):
                if name.lower() == lower:
                    return i
    if index is not None and 0 <= index < len(ARKIT_BLENDSHAPES):
        return index
    raise FrameError("unknown ARKit blendshape %r; valid: an index 0..51 or one of %s"
                     % (key, ", ".join(ARKIT_BLENDSHAPES)))


# ---------------------------------------------------------------------------------------
# Producer frames: JSON text and binary FWP2 and FWP1


def _frame_seq(frame: Mapping[str, Any]) -> int:
    if not isinstance(frame, Mapping):
        raise FrameError("a frame is a mapping (a JSONL object), not %s" % type(frame).__name__)
    seq = frame.get("seq")
    if isinstance(seq, bool) or not isinstance(seq, int) or not 0 <= seq <= _U64_MAX:
        raise FrameError("frame %r: seq must be an integer 0..2^64-1" % (seq,))
    return seq


def _number(seq: int, field_name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FrameError("frame seq %d: %s: %r is not a number" % (seq, field_name, value))
    number = float(value)
    if not math.isfinite(number):
        raise FrameError("frame seq %d: %s: %r is not a finite number" % (seq, field_name, value))
    return number


def _f32(seq: int, field_name: str, value: Any) -> float:
    number = _number(seq, field_name, value)
    try:
        struct.pack("<f", number)
    except OverflowError:
        raise FrameError("frame seq %d: %s: %r is beyond the range of f32"
                         % (seq, field_name, value)) from None
    return number


def _sparse(seq: int, frame: Mapping[str, Any], key: str,
            resolve: Any) -> List[Tuple[int, float]]:
    value = frame.get(key)
    if value is None:
        return []
    if not isinstance(value, Mapping):
        raise FrameError("frame seq %d: %s must be an object (name -> value)" % (seq, key))
    entries: Dict[int, Tuple[Any, float]] = {}
    for name, weight in value.items():
        field_name = "%s.%s" % (key, name)
        try:
            index = resolve(name)
        except FrameError as e:
            raise FrameError("frame seq %d: %s: %s" % (seq, field_name, e)) from None
        if index in entries:
            raise FrameError("frame seq %d: %s: names the same entry as %s.%s"
                             % (seq, field_name, key, entries[index][0]))
        entries[index] = (name, _f32(seq, field_name, weight))
    return sorted((index, w) for index, (_, w) in entries.items())


def _label_bytes(label: str) -> bytes:
    """UTF-8, at most 255 bytes, cut at a character boundary (as the server's encoder)."""
    data = label.encode("utf-8")
    if len(data) <= 255:
        return data
    end = 255
    while end > 0 and (data[end] & 0xC0) == 0x80:
        end -= 1
    return data[:end]


@dataclass
class _BinaryContent:
    """A frame's content checked for a binary layout: sorted ``(index, value)`` lists,
    f32-range numbers, None for what the frame does not give."""

    seq: int
    t: float
    au: List[Tuple[int, float]]
    faps: List[Tuple[int, float]]
    arkit: List[Tuple[int, float]]
    rotation: Optional[List[float]]
    translation: Optional[List[float]]
    label: Optional[bytes]
    viseme: bytes


def _binary_content(frame: Mapping[str, Any], layout: str,
                    json_only: Tuple[str, ...]) -> _BinaryContent:
    """Checks a frame once for both binary layouts, so that FWP1 and FWP2 refuse the same
    content with the same :class:`FrameError`; ``json_only`` are the keys ``layout``
    cannot carry."""
    seq = _frame_seq(frame)
    unknown = [k for k in frame if k not in _FRAME_KEYS]
    if unknown:
        raise FrameError("frame seq %d: unknown key %r; valid: %s"
                         % (seq, unknown[0], ", ".join(_FRAME_KEYS)))
    refused = [k for k in json_only if frame.get(k) is not None]
    if refused:
        raise FrameError("frame seq %d: %s cannot carry %s; send this frame as JSON text"
                         % (seq, layout, ", ".join(refused)))
    if "t" not in frame:
        raise FrameError("frame seq %d: t (seconds) is missing" % seq)
    t = _number(seq, "t", frame["t"])
    au = _sparse(seq, frame, "au", animation_unit_index)
    faps = _sparse(seq, frame, "fap", fap_number)
    arkit = _sparse(seq, frame, "arkit", arkit_index)
    rotation = _vector3(seq, "head_rotation_rad", "[rx, ry, rz]", frame.get("head_rotation_rad"))
    translation = _vector3(seq, "head_translation", "[x, y, z]", frame.get("head_translation"))
    label = frame.get("label")
    if label is not None and not isinstance(label, str):
        raise FrameError("frame seq %d: label must be a string or null" % seq)
    return _BinaryContent(seq, t, au, faps, arkit, rotation, translation,
                          None if label is None else _label_bytes(label),
                          _viseme_bytes(seq, frame.get("viseme")))


def _vector3(seq: int, key: str, shape: str, value: Any) -> Optional[List[float]]:
    """Three finite f32 numbers, or None when the frame does not give ``key``."""
    if value is None:
        return None
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise FrameError("frame seq %d: %s must be %s" % (seq, key, shape))
    return [_f32(seq, "%s[%d]" % (key, k), x) for k, x in enumerate(value)]


def _index_values(entries: Sequence[Tuple[int, float]], index_format: str) -> bytes:
    """A count (u16), then ``(index, f32 value)`` per entry: the au, fap and arkit lists
    of both binary layouts."""
    out = bytearray(struct.pack("<H", len(entries)))
    for index, value in entries:
        out += struct.pack("<" + index_format + "f", index, value)
    return bytes(out)


def encode_fwp1(frame: Mapping[str, Any]) -> bytes:
    """Encodes a JSONL-style frame (``seq``, ``t``, ``label``, ``au``, ``fap``, ``arkit``,
    ``head_rotation_rad``, ``viseme``) as a binary ``FWP1`` message (PROTOCOL.md,
    little-endian), the frozen layout every server reads.

    Unit, FAP and blendshape keys may be names or indices, as in JSONL; a viseme is FAP 1
    (``{"select1","select2","blend","definition"}``), ``{"oculus": 10 or "aa"}`` or
    ``{"microsoft": 21}``. Raises :class:`FrameError` for anything FWP1 cannot carry
    (``head_translation``, ``controls``, ``expression``: send such frames as JSON text or
    FWP2), for unknown keys and names, and for values that are not finite f32 numbers. A
    label longer than 255 UTF-8 bytes is cut at a character boundary, as the server cuts
    labels."""
    c = _binary_content(frame, "FWP1", _JSON_ONLY_KEYS)
    flags = ((1 if c.rotation is not None else 0) | (2 if c.label is not None else 0)
             | (4 if c.viseme else 0))
    out = bytearray(b"FWP1")
    out += struct.pack("<QdB", c.seq, c.t, flags)
    out += _index_values(c.au, "H") + _index_values(c.faps, "B") + _index_values(c.arkit, "B")
    if c.rotation is not None:
        out += struct.pack("<3f", *c.rotation)
    if c.label is not None:
        out += struct.pack("<B", len(c.label)) + c.label
    return bytes(out + c.viseme)


#: FWP2's section kinds (PROTOCOL.md, "Producer WebSocket").
_FWP2_AU, _FWP2_FAP, _FWP2_ARKIT, _FWP2_HEAD_ROTATION, _FWP2_HEAD_TRANSLATION, _FWP2_LABEL, \
    _FWP2_VISEME = range(1, 8)


def encode_fwp2(frame: Mapping[str, Any]) -> bytes:
    """Encodes a JSONL-style frame as a binary ``FWP2`` message: a 21-byte header (magic,
    seq, t, section count), then one section (kind u8, length u32, body) per thing the
    frame gives, in kind order: ``au``, ``fap``, ``arkit``, ``head_rotation``,
    ``head_translation``, ``label``, ``viseme``. What the frame leaves out (or gives
    empty) has no section: every frame is a full state, so absent means at rest.

    The same content as :func:`encode_fwp1` plus ``head_translation`` (mask units), with
    the same checks (a :class:`FrameError` for the same frames); ``controls`` and
    ``expression`` still need JSON text."""
    c = _binary_content(frame, "FWP2", tuple(k for k in _JSON_ONLY_KEYS if k != "head_translation"))
    sections: List[Tuple[int, bytes]] = []
    for kind, entries, index_format in ((_FWP2_AU, c.au, "H"), (_FWP2_FAP, c.faps, "B"),
                                        (_FWP2_ARKIT, c.arkit, "B")):
        if entries:
            sections.append((kind, _index_values(entries, index_format)))
    if c.rotation is not None:
        sections.append((_FWP2_HEAD_ROTATION, struct.pack("<3f", *c.rotation)))
    if c.translation is not None:
        sections.append((_FWP2_HEAD_TRANSLATION, struct.pack("<3f", *c.translation)))
    if c.label is not None:
        sections.append((_FWP2_LABEL, struct.pack("<B", len(c.label)) + c.label))
    if c.viseme:
        sections.append((_FWP2_VISEME, c.viseme))
    out = bytearray(b"FWP2")
    out += struct.pack("<QdB", c.seq, c.t, len(sections))
    for kind, body in sections:
        out += struct.pack("<BI", kind, len(body)) + body
    return bytes(out)


def _viseme_bytes(seq: int, viseme: Any) -> bytes:
    """The 5 viseme bytes (scheme, then 4 values) of FWP1 and of FWP2's ``viseme``
    section, or b"" for none."""
    if viseme is None:
        return b""
    if not isinstance(viseme, Mapping):
        raise FrameError("frame seq %d: viseme must be an object or null" % seq)
    if set(viseme) == {"oculus"}:
        value = viseme["oculus"]
        if isinstance(value, str):
            if value not in OCULUS_VISEMES:
                raise FrameError("frame seq %d: viseme.oculus %r: expected one of %s"
                                 % (seq, value, ", ".join(OCULUS_VISEMES)))
            value = OCULUS_VISEMES.index(value)
        return bytes([1, _byte(seq, "viseme.oculus", value), 0, 0, 0])
    if set(viseme) == {"microsoft"}:
        return bytes([2, _byte(seq, "viseme.microsoft", viseme["microsoft"]), 0, 0, 0])
    fields = ("select1", "select2", "blend", "definition")
    if set(viseme) != set(fields):
        raise FrameError("frame seq %d: viseme needs %s, or oculus, or microsoft"
                         % (seq, ", ".join(fields)))
    return bytes([0] + [_byte(seq, "viseme." + f, viseme[f]) for f in fields])


def _byte(seq: int, field: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 255:
        raise FrameError("frame seq %d: %s must be an integer 0..255, got %r" % (seq, field, value))
    return value


def encode_json(frame: Mapping[str, Any]) -> str:
    """One frame as a compact JSONL line (no newline). The server validates names and
    values; this only refuses what JSON cannot hold (NaN, infinities, non-JSON types)."""
    seq = _frame_seq(frame)
    if "t" not in frame:
        raise FrameError("frame seq %d: t (seconds) is missing" % seq)
    try:
        return json.dumps(frame, separators=(",", ":"), allow_nan=False, ensure_ascii=False)
    except (TypeError, ValueError) as e:
        raise FrameError("frame seq %d: cannot be written as JSON: %s" % (seq, e)) from None


def read_jsonl(path: str) -> Iterator[Dict[str, Any]]:
    """Reads a facewire JSONL file one line at a time (blank lines skipped)."""
    with open(path, "r", encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                value = json.loads(line)
            except ValueError as e:
                raise FrameError("%s: line %d: invalid JSON: %s" % (path, number, e)) from None
            if not isinstance(value, dict):
                raise FrameError("%s: line %d: expected a JSON object" % (path, number))
            yield value


# ---------------------------------------------------------------------------------------
# Viewer frames (FWF2, FWF1) and the rest mesh (FWM1)


@dataclass
class LipRoughness:
    """Lip roughness of one frame: summary over the lip region, and the mean around each
    of the snapshot's ``lip_vertices``."""

    min: float
    max: float
    mean: float
    per_vertex: List[float]


@dataclass(frozen=True)
class LipFolds:
    """Folds of the lip region in one frame (FWF2's ``lip_folds`` section, FWF1's flag bit
    6), after the region's own rigid motion: ``turned_over_60`` and ``turned_over_90``
    count the lip triangles whose normal turned more than 60 and more than 90 degrees from
    rest (at most 65,535), and ``max_dihedral_increase_deg`` is the largest increase of a
    dihedral angle between two lip triangles over rest, degrees (finite, not negative)."""

    turned_over_60: int
    turned_over_90: int
    max_dihedral_increase_deg: float


@dataclass
class RigidMotion:
    """A rigid motion of head units, ``world = rotate(rotation, p) + translation``: the
    head's own motion in a frame, for a deformed position ``p``. ``rotation`` is a unit quaternion
    ``(x, y, z, w)``."""

    rotation: Tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    translation: Tuple[float, float, float] = (0.0, 0.0, 0.0)

    def apply(self, p: Tuple[float, float, float]) -> Tuple[float, float, float]:
        x, y, z, w = self.rotation
        px, py, pz = p
        # v' = v + 2 w (q x v) + 2 q x (q x v), q = (x, y, z)
        cx, cy, cz = y * pz - z * py, z * px - x * pz, x * py - y * px
        ccx, ccy, ccz = y * cz - z * cy, z * cx - x * cz, x * cy - y * cx
        tx, ty, tz = self.translation
        return (px + 2 * (w * cx + ccx) + tx, py + 2 * (w * cy + ccy) + ty,
                pz + 2 * (w * cz + ccz) + tz)


@dataclass
class PartDeltas:
    """A part's deltas in one frame (FWF2's ``part_deltas`` section, FWF1's tongue deltas,
    flag bit 5): a shaped part's (the tongue's) shape against that part's rest mesh.

    ``part`` is the part's index in the snapshot's ``parts``, ``vertex_count`` its
    vertices; ``moved`` holds ``(vertex, cx, cy, cz)`` as :attr:`ViewerFrame.moved` does,
    in counts of ``step`` head units (the frame's step). The deltas come before the jaw's
    and the head's motions: :meth:`ViewerFrame.place_part` applies all three."""

    part: int
    vertex_count: int
    moved: List[Tuple[int, int, int, int]]
    step: float

    def apply(self, rest: Sequence[Tuple[float, float, float]]) -> List[Tuple[float, float, float]]:
        """The part's shaped positions: ``rest`` (one ``(x, y, z)`` per vertex of the part,
        as its :class:`RestMesh` from :meth:`Client.part_mesh`) plus the deltas, before any
        motion. Vertices that did not move share ``rest``'s tuples."""
        if len(rest) != self.vertex_count:
            raise ProtocolError("the frame shapes part %d as %d vertices, its rest mesh has %d"
                                % (self.part, self.vertex_count, len(rest)),
                                field="tongue vertex_count")
        return _apply_deltas(rest, self.moved, self.step)


def _apply_deltas(rest: Sequence[Tuple[float, float, float]],
                  moved: Sequence[Tuple[int, int, int, int]],
                  step: float) -> List[Tuple[float, float, float]]:
    out = list(rest)
    for index, cx, cy, cz in moved:
        x, y, z = out[index]
        out[index] = (x + cx * step, y + cy * step, z + cz * step)
    return out


@dataclass
class ViewerFrame:
    """A decoded viewer frame, ``FWF2`` or ``FWF1`` (the same content in either layout).

    ``moved`` holds ``(vertex, cx, cy, cz)``: the quantized delta of every vertex that
    moved, in counts of ``step`` head units. ``positions`` is filled by :class:`Viewer`
    (or :meth:`apply`): one ``(x, y, z)`` tuple per vertex, head units, ``rest + counts x
    step``, before the head's own motion ``head`` (:meth:`place` applies it). ``jaw`` is the
    jaw's motion, which places the parts that move with it (before ``head``), and
    ``parts`` the deltas of every part the frame shapes (:class:`PartDeltas`, before the
    jaw's motion), in part order, empty while every part is at rest; :attr:`tongue` is the
    first of them; :meth:`place_part` places any part. ``eyes`` maps the index of each
    turned eyeball (in the snapshot's ``eyes``) to its turn about its centre, before the
    head's motion (``FWF2`` only; eyes not in it look ahead); :meth:`place_eye` places
    one. ``folds`` is the lip region's folds
    (:class:`LipFolds`), None when the frame has none. ``face`` is the per-vertex values the
    viewer asked for (the snapshot's ``heat``), ``byte / 255 x face_max`` each, None when
    it asked for none. Times: ``producer_time_s`` is the producer's ``t``; the ``_us``
    fields are µs since the Unix epoch on the server's clock."""

    seq: int
    producer_time_s: float
    server_receive_us: int
    server_send_us: int
    step: float
    vertex_count: int
    moved: List[Tuple[int, int, int, int]]
    lip: LipRoughness
    label: Optional[str]
    face: Optional[List[float]] = None
    head: RigidMotion = field(default_factory=RigidMotion)
    jaw: RigidMotion = field(default_factory=RigidMotion)
    parts: List[PartDeltas] = field(default_factory=list)
    folds: Optional[LipFolds] = None
    positions: Optional[List[Tuple[float, float, float]]] = None
    face_max: Optional[float] = None
    eyes: Dict[int, RigidMotion] = field(default_factory=dict)

    @property
    def tongue(self) -> Optional[PartDeltas]:
        """The first part's deltas, None when no part is shaped: the server shapes only the
        tongue, and callers written before :attr:`parts` read it here."""
        return self.parts[0] if self.parts else None

    def apply(self, rest: Sequence[Tuple[float, float, float]]) -> List[Tuple[float, float, float]]:
        """The deformed positions: ``rest`` (one ``(x, y, z)`` per vertex, as
        :attr:`RestMesh.positions`) plus the deltas. Vertices that did not move share
        ``rest``'s tuples."""
        if len(rest) != self.vertex_count:
            raise ProtocolError("the frame has %d vertices, the rest mesh %d"
                                % (self.vertex_count, len(rest)), field="vertex_count")
        return _apply_deltas(rest, self.moved, self.step)

    def place(self, positions: Sequence[Tuple[float, float, float]]) -> List[Tuple[float, float, float]]:
        """Deformed positions (from :meth:`apply`) moved by the head's motion: where the
        head is in the world."""
        return [self.head.apply(p) for p in positions]

    def place_eye(self, index: int,
                  rest: Sequence[Tuple[float, float, float]]) -> List[Tuple[float, float, float]]:
        """Where eyeball ``index`` of the snapshot's ``eyes`` is in the world in this frame,
        from its rest positions (:meth:`Client.part_mesh` of its name): turned by its entry
        in :attr:`eyes` (none: looking ahead), then moved by the head's motion."""
        turn = self.eyes.get(index, RigidMotion())
        return [self.head.apply(turn.apply(p)) for p in rest]

    def place_part(self, index: int, role: str,
                   rest: Sequence[Tuple[float, float, float]]) -> List[Tuple[float, float, float]]:
        """Where part ``index`` of the snapshot's ``parts`` is in the world in this frame,
        from its ``role`` and its rest positions (:meth:`Client.part_mesh`): a ``skull``
        part moved by the head's motion, a ``jaw`` or ``tongue`` part by the jaw's and then
        the head's, and a part this frame's :attr:`parts` shape shaped by its deltas first
        (at rest when the frame has none for it)."""
        if role not in ("skull", "jaw", "tongue"):
            raise ProtocolError("unknown part role %r; expected skull, jaw or tongue" % (role,),
                                field="role")
        deltas = next((d for d in self.parts if d.part == index), None)
        shaped = rest if deltas is None else deltas.apply(rest)
        if role == "skull":
            return [self.head.apply(p) for p in shaped]
        head, jaw = self.head, self.jaw
        return [head.apply(jaw.apply(p)) for p in shaped]


@dataclass
class RestMesh:
    """The rest mesh (``mesh.bin``): one ``(x, y, z)`` per vertex in head units, and
    triangles as 0-based vertex indices."""

    positions: List[Tuple[float, float, float]]
    triangles: List[Tuple[int, int, int]]
    mm_per_unit: float


class _Reader:
    """Little-endian reads that name the field on a short message.

    A reader may be bounded to one section's body (``start``..``end`` of the message, the
    section's name in ``section``): a read past the body then names the field cut short,
    as PROTOCOL.md names a section shorter than its fields, and ``at`` stays an offset in
    the whole message so that errors point at the right byte."""

    def __init__(self, data: bytes, start: int = 0, end: Optional[int] = None,
                 section: Optional[str] = None):
        self.data = data
        self.at = start
        self.end = len(data) if end is None else end
        self.section = section

    def take(self, n: int, name: str) -> bytes:
        end = self.at + n
        if n < 0 or end > self.end:
            if self.section is not None:
                raise ProtocolError("section %s too short: needs bytes %d..%d, it ends at %d"
                                    % (self.section, self.at, end, self.end),
                                    field=name, at=self.at)
            raise ProtocolError("message too short: needs bytes %d..%d, the message has %d"
                                % (self.at, end, len(self.data)), field=name)
        chunk = self.data[self.at:end]
        self.at = end
        return chunk

    def unpack(self, fmt: str, name: str) -> Tuple[Any, ...]:
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt), name))

    def label(self) -> str:
        (length,) = self.unpack("B", "label length")
        at = self.at
        raw = self.take(length, "label")
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise ProtocolError("not UTF-8", field="label", at=at) from None

    def finish(self) -> None:
        extra = self.end - self.at
        if extra:
            raise ProtocolError("%d unexpected byte(s) after the message" % extra)


def _inflate(stored: bytes, limit: int, at: int) -> bytes:
    inflater = zlib.decompressobj(-15)  # raw deflate, RFC 1951
    try:
        out = inflater.decompress(stored, limit + 1)
    except zlib.error as e:
        raise ProtocolError("bad deflate data: %s" % e, field="delta block", at=at) from None
    if len(out) > limit:
        raise ProtocolError("inflates past %d bytes" % limit, field="delta block", at=at)
    if not inflater.eof:
        raise ProtocolError("truncated deflate data", field="delta block", at=at)
    return out


def _varint_tail(block: bytes, i: int, first: int) -> Tuple[int, int]:
    """Finishes an LEB128 varint whose first byte (at i - 1) had the high bit set."""
    value = first & 0x7F
    shift = 7
    while True:
        if i >= len(block) or shift > 63:
            raise IndexError
        b = block[i]
        i += 1
        value |= (b & 0x7F) << shift
        if b < 0x80:
            return value, i
        shift += 7


def decode_viewer_frame(data: bytes) -> ViewerFrame:
    """Decodes one binary viewer frame of either layout, by its magic: ``FWF2`` (what
    :class:`Viewer` asks for) or the frozen ``FWF1`` (what servers before ``FWF2`` send,
    and what a viewer gets that names no ``format``)."""
    magic = bytes(data[:4])
    if magic == b"FWF2":
        return decode_fwf2(data)
    if magic == b"FWF1":
        return decode_fwf1(data)
    raise ProtocolError("bad magic %r: expected b'FWF2' or b'FWF1'" % magic, field="magic", at=0)


#: FWF2's section kinds (PROTOCOL.md, "Viewer frame (FWF2)").
_FWF2_DELTAS, _FWF2_LIP_ROUGHNESS, _FWF2_LABEL, _FWF2_HEAD_MOTION, _FWF2_JAW_MOTION, \
    _FWF2_LIP_FOLDS, _FWF2_PART_DELTAS, _FWF2_HEAT, _FWF2_EYE_MOTION = range(1, 10)
#: Their names, as PROTOCOL.md and a snapshot's ``sections`` give them, and as errors name
#: a kind given twice or missing.
_FWF2_SECTIONS: Dict[int, str] = {
    _FWF2_DELTAS: "deltas", _FWF2_LIP_ROUGHNESS: "lip_roughness", _FWF2_LABEL: "label",
    _FWF2_HEAD_MOTION: "head_motion", _FWF2_JAW_MOTION: "jaw_motion",
    _FWF2_LIP_FOLDS: "lip_folds", _FWF2_PART_DELTAS: "part_deltas", _FWF2_HEAT: "heat",
    _FWF2_EYE_MOTION: "eye_motion",
}
#: Kinds a frame may hold several of: one per part, one per eye.
_FWF2_REPEATED = (_FWF2_PART_DELTAS, _FWF2_EYE_MOTION)


def _next_section(r: _Reader, number: int, count: int,
                  names: Mapping[int, str] = _FWF2_SECTIONS) -> Tuple[int, int, _Reader]:
    """Section ``number`` (0-based) of ``count``: its kind, where it starts, and a reader
    bounded to its body, which knows the section's name from ``names`` (the layout's kinds;
    ``section K`` for a kind this client does not know). Framing errors are the field
    ``section``, as PROTOCOL.md names them (the message says which kind): a section that
    runs past the message, or a message that ends where a counted section should start."""
    at = r.at
    if at >= r.end:
        raise ProtocolError("the message ends after %d of its %d sections" % (number, count),
                            field="section", at=at)
    (kind,) = r.unpack("B", "section")
    name = names.get(kind, "section %d" % kind)
    (length,) = r.unpack("I", "section")
    left = r.end - r.at
    if length > left:
        raise ProtocolError("section of kind %d claims %d bytes, %d are left"
                            % (kind, length, left), field="section", at=at)
    body = _Reader(r.data, r.at, r.at + length, name)
    r.at += length
    return kind, at, body


def _section_deltas(r: _Reader,
                    moved_name: str) -> Tuple[float, int, List[Tuple[int, int, int, int]]]:
    """step, vertex_count, moved, encoding and the delta block, as the ``deltas`` and
    ``part_deltas`` sections both carry them: ``(step, vertex_count, moved entries)``."""
    (step,) = r.unpack("f", "step")
    (vertex_count,) = r.unpack("I", "vertex_count")
    moved_at = r.at
    (moved_count,) = r.unpack("I", moved_name)
    if moved_count > vertex_count:
        raise ProtocolError("%d moved of %d vertices" % (moved_count, vertex_count),
                            field=moved_name, at=moved_at)
    encoding_at = r.at
    (encoding,) = r.unpack("B", "encoding")
    if encoding not in (0, 1):
        raise ProtocolError("encoding %d in %s: expected 0 (plain) or 1 (raw deflate)"
                            % (encoding, r.section), field="encoding", at=encoding_at)
    return step, vertex_count, _read_deltas(r, encoding == 1, moved_count, vertex_count,
                                            moved_name, moved_at)


def decode_fwf2(data: bytes) -> ViewerFrame:
    """Decodes one sectioned viewer frame (``FWF2``), checking every length.

    After the 37-byte header (magic, seq, t, receive and send times, section count) come
    the sections, each kind (u8), length (u32) and body, in any order. The layout grows
    without breaking this decoder (PROTOCOL.md, "Versions and growth"): a section of a kind
    it does not know is skipped, and so is the end of a known section past the fields read
    here (fields from a later server). What cannot be read is a :class:`ProtocolError`
    naming the field as PROTOCOL.md does (and the Rust and JavaScript decoders): a section
    running past the message or fewer sections than counted (``section``, the message
    saying which kind), a section shorter than its fields (the field cut short: ``step``,
    ``moved``, ``delta block``, ``head motion``, ``lip folds``, ``part``, ``heat``, ...),
    bytes after the last section (``end``), a known kind given twice (the section's name;
    ``part_deltas`` for a part's deltas twice), a frame without ``deltas`` or
    ``lip_roughness`` (that name), an ``encoding`` other than 0 (plain) or 1 (raw
    deflate), heat values not one per vertex (``heat count``), and every check
    :func:`decode_fwf1` makes, with its names (``moved``, ``delta block``, ``index gap``,
    ``head motion``, ``jaw motion``, ``lip folds``, ``label``; ``part moved`` for a part's
    moved count)."""
    r = _Reader(bytes(data))
    magic = r.take(4, "magic")
    if magic != b"FWF2":
        raise ProtocolError("bad magic %r: expected b'FWF2'" % magic, field="magic", at=0)
    seq, producer_time_s, receive_us, send_us = r.unpack("QdQQ", "header")
    (count,) = r.unpack("B", "section count")
    deltas: Optional[Tuple[float, int, List[Tuple[int, int, int, int]]]] = None
    lip: Optional[LipRoughness] = None
    label: Optional[str] = None
    head = RigidMotion()
    jaw = RigidMotion()
    folds: Optional[LipFolds] = None
    parts: Dict[int, PartDeltas] = {}
    eyes: Dict[int, RigidMotion] = {}
    heat: Optional[Tuple[int, int, float, bytes]] = None  # count's offset, count, max, bytes
    seen: Dict[int, int] = {}
    for number in range(count):
        kind, at, body = _next_section(r, number, count)
        name = body.section
        if kind in _FWF2_SECTIONS and kind not in _FWF2_REPEATED:
            if kind in seen:
                raise ProtocolError("section %s (kind %d) given twice, first at byte %d"
                                    % (name, kind, seen[kind]), field=name, at=at)
            seen[kind] = at
        if kind == _FWF2_DELTAS:
            deltas = _section_deltas(body, "moved")
        elif kind == _FWF2_LIP_ROUGHNESS:
            lip = _lip_roughness(body)
        elif kind == _FWF2_LABEL:
            label = body.label()
        elif kind == _FWF2_HEAD_MOTION:
            head = _rigid_motion(body, "head motion")
        elif kind == _FWF2_JAW_MOTION:
            jaw = _rigid_motion(body, "jaw motion")
        elif kind == _FWF2_LIP_FOLDS:
            folds = _lip_folds(body)
        elif kind == _FWF2_PART_DELTAS:
            (part,) = body.unpack("B", "part")
            if part in parts:
                raise ProtocolError("part_deltas given twice for part %d" % part,
                                    field="part_deltas", at=at)
            step, part_vertices, part_moved = _section_deltas(body, "part moved")
            parts[part] = PartDeltas(part, part_vertices, part_moved, step)
        elif kind == _FWF2_EYE_MOTION:
            (eye,) = body.unpack("B", "eye")
            if eye in eyes:
                raise ProtocolError("eye_motion given twice for eye %d" % eye,
                                    field="eye_motion", at=at)
            eyes[eye] = _rigid_motion(body, "eye motion")
        elif kind == _FWF2_HEAT:
            (heat_max,) = body.unpack("f", "heat max")
            count_at = body.at
            (heat_count,) = body.unpack("I", "heat count")
            heat = (count_at, heat_count, heat_max, body.take(heat_count, "heat"))
        # any other kind: from a later server, skipped (_next_section passed its body)
    if r.at != r.end:
        raise ProtocolError("%d byte(s) after the last of %d sections" % (r.end - r.at, count),
                            field="end", at=r.at)
    if deltas is None:
        raise ProtocolError("no deltas section: every frame has one", field="deltas")
    if lip is None:
        raise ProtocolError("no lip_roughness section: every frame has one", field="lip_roughness")
    step, vertex_count, moved = deltas
    face: Optional[List[float]] = None
    face_max: Optional[float] = None
    if heat is not None:
        heat_at, heat_count, face_max, raw = heat
        if heat_count != vertex_count:
            raise ProtocolError("%d values for %d vertices" % (heat_count, vertex_count),
                                field="heat count", at=heat_at)
        face = _heat_values(face_max, raw)
    return ViewerFrame(
        seq=seq,
        producer_time_s=producer_time_s,
        server_receive_us=receive_us,
        server_send_us=send_us,
        step=step,
        vertex_count=vertex_count,
        moved=moved,
        lip=lip,
        label=label,
        face=face,
        head=head,
        jaw=jaw,
        parts=[parts[k] for k in sorted(parts)],
        folds=folds,
        face_max=face_max,
        eyes=eyes,
    )


def decode_fwf1(data: bytes) -> ViewerFrame:
    """Decodes one frozen flag-bit viewer frame (``FWF1``), checking every length.

    The delta block holds ``moved`` entries: an LEB128 index gap (``index - previous - 1``,
    previous starting at -1), then dx, dy, dz as zigzag LEB128 differences from the
    previous entry's counts (starting from 0); it is raw deflate when flag bit 2 is set.
    With flag bit 5 the tongue's part index, vertex count, moved count and a delta block
    of its own (the same format) follow it: :attr:`ViewerFrame.parts`. With flag bit 6
    the lip folds (u16, u16, f32) follow the jaw's motion: :attr:`ViewerFrame.folds`."""
    r = _Reader(bytes(data))
    magic = r.take(4, "magic")
    if magic != b"FWF1":
        raise ProtocolError("bad magic %r: expected b'FWF1'" % magic, field="magic", at=0)
    (flags,) = r.unpack("B", "flags")
    r.take(3, "reserved")
    seq, producer_time_s, receive_us, send_us = r.unpack("QdQQ", "header")
    step, vertex_count, moved_count = r.unpack("fII", "step, vertex_count, moved")
    lip = _lip_roughness(r)
    label = r.label() if flags & 2 else None
    head = _rigid_motion(r, "head motion") if flags & 8 else RigidMotion()
    jaw = _rigid_motion(r, "jaw motion") if flags & 16 else RigidMotion()
    folds = _lip_folds(r) if flags & 64 else None
    if moved_count > vertex_count:
        raise ProtocolError("%d moved of %d vertices" % (moved_count, vertex_count),
                            field="moved", at=48)
    deflated = bool(flags & 4)
    moved = _read_deltas(r, deflated, moved_count, vertex_count, "moved", 48)
    parts: List[PartDeltas] = []
    if flags & 32:
        (part,) = r.unpack("B", "tongue part")
        (tongue_vertices,) = r.unpack("I", "tongue vertex_count")
        moved_at = r.at
        (tongue_moved,) = r.unpack("I", "tongue moved")
        if tongue_moved > tongue_vertices:
            raise ProtocolError("%d moved of %d vertices" % (tongue_moved, tongue_vertices),
                                field="tongue moved", at=moved_at)
        parts.append(PartDeltas(part, tongue_vertices,
                                _read_deltas(r, deflated, tongue_moved, tongue_vertices,
                                             "tongue moved", moved_at), step))
    face: Optional[List[float]] = None
    face_max: Optional[float] = None
    if flags & 1:
        (face_max,) = r.unpack("f", "face roughness max")
        face = _heat_values(face_max, r.take(vertex_count, "face roughness"))
    r.finish()
    return ViewerFrame(
        seq=seq,
        producer_time_s=producer_time_s,
        server_receive_us=receive_us,
        server_send_us=send_us,
        step=step,
        vertex_count=vertex_count,
        moved=moved,
        lip=lip,
        label=label,
        face=face,
        head=head,
        jaw=jaw,
        parts=parts,
        folds=folds,
        face_max=face_max,
    )


def _read_deltas(r: _Reader, deflated: bool, moved_count: int, vertex_count: int,
                 moved_name: str, moved_at: int) -> List[Tuple[int, int, int, int]]:
    """A delta block's length and the block (the head's or a part's, from the message or
    from a section's body), inflated first when ``deflated``: ``moved_count`` entries
    ``(vertex, cx, cy, cz)`` of vertices below ``vertex_count``. ``moved_name`` and
    ``moved_at`` name the moved count a block too small for it contradicts."""
    (block_length,) = r.unpack("I", "delta block length")
    block_at = r.at
    block = r.take(block_length, "delta block")
    if deflated:
        # An entry takes 4 to 40 bytes: never inflate past what the count allows.
        block = _inflate(block, moved_count * 40, block_at)
    if moved_count > len(block) // 4:
        raise ProtocolError("%d entries cannot fit in %d bytes" % (moved_count, len(block)),
                            field=moved_name, at=moved_at)

    moved: List[Tuple[int, int, int, int]] = []
    append = moved.append
    i = 0
    previous = -1
    qx = qy = qz = 0
    try:
        for _ in range(moved_count):
            b = block[i]
            i += 1
            gap, i = (b, i) if b < 0x80 else _varint_tail(block, i, b)
            index = previous + 1 + gap
            if index >= vertex_count:
                raise ProtocolError("vertex %d is out of range (%d vertices)"
                                    % (index, vertex_count), field="index gap", at=block_at)
            b = block[i]
            i += 1
            z, i = (b, i) if b < 0x80 else _varint_tail(block, i, b)
            qx += (z >> 1) ^ -(z & 1)
            b = block[i]
            i += 1
            z, i = (b, i) if b < 0x80 else _varint_tail(block, i, b)
            qy += (z >> 1) ^ -(z & 1)
            b = block[i]
            i += 1
            z, i = (b, i) if b < 0x80 else _varint_tail(block, i, b)
            qz += (z >> 1) ^ -(z & 1)
            append((index, qx, qy, qz))
            previous = index
    except IndexError:
        raise ProtocolError("truncated or over-long varint in entry %d of %d"
                            % (len(moved), moved_count), field="delta block", at=block_at) from None
    if i != len(block):
        raise ProtocolError("%d byte(s) left after %d entries" % (len(block) - i, moved_count),
                            field="delta block", at=block_at)
    return moved


def _lip_roughness(r: _Reader) -> LipRoughness:
    """min, max, mean (3 x f32), n (u8), then n x f32: the same bytes in both layouts."""
    (lip_min,) = r.unpack("f", "lip min")
    (lip_max,) = r.unpack("f", "lip max")
    (lip_mean,) = r.unpack("f", "lip mean")
    (lip_count,) = r.unpack("B", "lip_count")
    per_vertex = list(r.unpack("%df" % lip_count, "lip roughness"))
    return LipRoughness(lip_min, lip_max, lip_mean, per_vertex)


def _rigid_motion(r: _Reader, name: str) -> RigidMotion:
    """7 x f32: a unit rotation quaternion x, y, z, w and a translation, all finite."""
    at = r.at
    values = r.unpack("7f", name)
    if not all(math.isfinite(v) for v in values):
        raise ProtocolError("%s not finite: %r" % (name, values), field=name, at=at)
    length = math.sqrt(sum(v * v for v in values[:4]))
    if abs(length - 1.0) > 1e-4:
        raise ProtocolError("%s: rotation quaternion of length %g, not 1" % (name, length),
                            field=name, at=at)
    return RigidMotion(rotation=tuple(values[:4]), translation=tuple(values[4:]))


def _lip_folds(r: _Reader) -> LipFolds:
    """u16 triangles turned over 60 degrees, u16 over 90, f32 the largest dihedral
    increase in degrees (finite, not negative)."""
    turned_over_60, turned_over_90 = r.unpack("HH", "lip folds")
    at = r.at
    (max_increase,) = r.unpack("f", "lip folds")
    if not (math.isfinite(max_increase) and max_increase >= 0.0):
        raise ProtocolError("largest dihedral increase %r" % (max_increase,),
                            field="lip folds", at=at)
    return LipFolds(turned_over_60, turned_over_90, max_increase)


def _heat_values(top: float, raw: bytes) -> List[float]:
    """Per-vertex values from their bytes: ``byte / 255 x top`` (both layouts)."""
    return [b / 255.0 * top for b in raw]


def decode_mesh(data: bytes) -> RestMesh:
    """Decodes ``mesh.bin`` (``FWM1``): counts, mm per head unit, positions, triangles."""
    r = _Reader(bytes(data))
    magic = r.take(4, "magic")
    if magic != b"FWM1":
        raise ProtocolError("bad magic %r: expected b'FWM1'" % magic, field="magic", at=0)
    vertices, triangles, mm_per_unit = r.unpack("IIf", "header")
    flat = r.unpack("%df" % (3 * vertices), "positions")
    corners = r.unpack("%dI" % (3 * triangles), "triangles")
    r.finish()
    if any(c >= vertices for c in corners):
        raise ProtocolError("a triangle names a vertex beyond %d" % vertices, field="triangles")
    return RestMesh(
        positions=list(zip(flat[0::3], flat[1::3], flat[2::3])),
        triangles=list(zip(corners[0::3], corners[1::3], corners[2::3])),
        mm_per_unit=mm_per_unit,
    )


# ---------------------------------------------------------------------------------------
# Audio chunks: FWA1 (PROTOCOL.md, "Audio (FWA1)"; proto/src/audio_chunk.rs)

#: FWA1's section kinds, and their names as errors and a viewer's ``audio=`` give them.
_FWA1_PCM, _FWA1_OPUS = 1, 2
_FWA1_SECTIONS: Dict[int, str] = {_FWA1_PCM: "pcm", _FWA1_OPUS: "opus"}
#: RFC 6716's largest packet, bytes.
_MAX_OPUS_PACKET = 1275
#: The longest an Opus packet plays, in 48 kHz samples (120 ms).
_MAX_OPUS_SAMPLES = 5760


@dataclass
class AudioChunk:
    """A piece of a stream's voice (``FWA1``). ``t_s`` is the stream time of its first
    sample in the producer's seconds, the clock of the parameter frames' ``t``: a player
    lines the voice up with :attr:`ViewerFrame.producer_time_s` by it. ``server_receive_us``
    is when the server received it (µs since the Unix epoch), 0 in what a producer sends.

    ``codec`` is ``"pcm"``, with ``samples`` (16-bit mono, at ``sample_rate``: 16000, 24000
    or 48000 Hz), or ``"opus"``, with ``packet`` (one Opus packet, mono, timed at 48 kHz,
    its ``sample_rate``); the other of the two is empty. ``ignored`` lists the section kinds
    :func:`decode_fwa1` skipped because it does not know them (from a later sender)."""

    t_s: float
    server_receive_us: int
    codec: str
    sample_rate: int
    samples: List[int] = field(default_factory=list)
    packet: bytes = b""
    ignored: List[int] = field(default_factory=list)

    @property
    def duration_s(self) -> float:
        """How long the chunk plays, seconds: its samples, or what its Opus packet's table
        of contents says (:func:`opus_packet_samples`); the next chunk may start here."""
        if self.codec == "opus":
            return opus_packet_samples(self.packet) / OPUS_RATE
        return len(self.samples) / self.sample_rate


def opus_packet_samples(packet: bytes, at: Optional[int] = None) -> int:
    """How many 48 kHz samples an Opus packet plays for, read from its table of contents
    (RFC 6716, section 3.1) as the server times it: the frame size its configuration (the
    first byte's top five bits) names, times its frame count (code 0: one frame; codes 1
    and 2: two; code 3: the low six bits of the second byte). Nothing past that is read: the
    server relays packets without decoding them, so this is all it checks.

    Raises :class:`ProtocolError` with field ``opus`` (at byte ``at`` when given) for an
    empty packet, a code 3 packet without its frame count, no frames, or more than 120 ms."""
    if not packet:
        raise ProtocolError("an empty packet", field="opus", at=at)
    config = packet[0] >> 3
    # Frame sizes at 48 kHz: SILK-only (configs 0-11) 10, 20, 40, 60 ms; hybrid (12-15)
    # 10, 20 ms; CELT-only (16-31) 2.5, 5, 10, 20 ms.
    if config < 12:
        frame = (480, 960, 1920, 2880)[config % 4]
    elif config < 16:
        frame = (480, 960)[config % 2]
    else:
        frame = (120, 240, 480, 960)[config % 4]
    code = packet[0] & 3
    if code == 0:
        frames = 1
    elif code in (1, 2):
        frames = 2
    elif len(packet) < 2:
        raise ProtocolError("code 3 packet without its frame count", field="opus", at=at)
    else:
        frames = packet[1] & 0x3F
    if frames == 0 or frame * frames > _MAX_OPUS_SAMPLES:
        raise ProtocolError("%d frame(s) of %d samples: a packet holds 1 to 120 ms"
                            % (frames, frame), field="opus", at=at)
    return frame * frames


def _pcm_bytes(t_s: float, samples: Sequence[int]) -> bytes:
    """Samples as little-endian i16, refusing what 16-bit PCM cannot hold."""
    try:
        return struct.pack("<%dh" % len(samples), *samples)
    except struct.error as e:
        raise FrameError("audio at t %s s: PCM samples are integers -32768..32767 (%s)"
                         % (t_s, e)) from None


def encode_fwa1(chunk: AudioChunk) -> bytes:
    """Encodes an audio chunk as an ``FWA1`` message: magic, ``t_s`` (f64),
    ``server_receive_us`` (u64), a section count of 1, then one ``pcm`` section (sample
    rate u32, count u32, count x i16) or one ``opus`` section (length u16, the packet).

    Raises :class:`FrameError` for what the layout cannot carry or :func:`decode_fwa1`
    (and the server) would refuse: a ``t_s`` that is not finite, a codec other than
    ``pcm`` and ``opus``, a PCM rate not in :data:`PCM_RATES`, a sample outside 16 bits, an
    Opus chunk not at 48 kHz, a packet over 1275 bytes or whose table of contents does not
    parse, and a chunk giving both samples and a packet. ``ignored`` is not written (the
    decoder keeps only the kinds it skipped, not their bodies)."""
    t_s = chunk.t_s
    if isinstance(t_s, bool) or not isinstance(t_s, (int, float)) or not math.isfinite(t_s):
        raise FrameError("audio chunk: t_s %r is not a finite number of seconds" % (t_s,))
    receive_us = chunk.server_receive_us
    if isinstance(receive_us, bool) or not isinstance(receive_us, int) \
            or not 0 <= receive_us <= _U64_MAX:
        raise FrameError("audio at t %s s: server_receive_us %r is not a u64"
                         % (t_s, receive_us))
    if chunk.codec == "pcm":
        if chunk.packet:
            raise FrameError("audio at t %s s: a pcm chunk carries samples, not a packet" % t_s)
        if chunk.sample_rate not in PCM_RATES:
            raise FrameError("audio at t %s s: PCM at %r Hz; the protocol takes %s"
                             % (t_s, chunk.sample_rate, ", ".join(map(str, PCM_RATES))))
        kind = _FWA1_PCM
        body = (struct.pack("<II", chunk.sample_rate, len(chunk.samples))
                + _pcm_bytes(t_s, chunk.samples))
    elif chunk.codec == "opus":
        packet = bytes(chunk.packet)
        if chunk.samples:
            raise FrameError("audio at t %s s: an opus chunk carries a packet, not samples" % t_s)
        if chunk.sample_rate != OPUS_RATE:
            raise FrameError("audio at t %s s: Opus is timed at %d Hz, not %r"
                             % (t_s, OPUS_RATE, chunk.sample_rate))
        if len(packet) > _MAX_OPUS_PACKET:
            raise FrameError("audio at t %s s: an Opus packet of %d bytes; at most %d"
                             % (t_s, len(packet), _MAX_OPUS_PACKET))
        try:
            opus_packet_samples(packet)
        except ProtocolError as e:
            raise FrameError("audio at t %s s: %s" % (t_s, e)) from None
        kind, body = _FWA1_OPUS, struct.pack("<H", len(packet)) + packet
    else:
        raise FrameError("audio at t %s s: codec %r: expected 'pcm' or 'opus'"
                         % (t_s, chunk.codec))
    return b"FWA1" + struct.pack("<dQBBI", t_s, receive_us, 1, kind, len(body)) + body


def decode_fwa1(data: bytes) -> AudioChunk:
    """Decodes one ``FWA1`` audio message with the Rust decoder's checks, in its order,
    and its names for what is wrong (:class:`ProtocolError`'s ``field``, PROTOCOL.md's
    table of refusals): ``magic``; a header cut short (``t_s``, ``server_receive_us``,
    ``section count``) or a ``t_s`` that is not finite (``t_s``); a section that runs past
    the message or fewer sections than counted (``section``), bytes after the last one
    (``end``, as :func:`decode_fwf2` names them); in a ``pcm`` section a rate not in
    :data:`PCM_RATES` (``sample_rate``) or a body cut short (``sample_rate``, ``pcm count``,
    ``pcm``); in an ``opus`` section a packet over 1275 bytes or whose table of contents
    does not parse (``opus``) or a body cut short (``opus length``, ``opus``); and neither,
    both, or one of them twice (``sound``).

    The layout grows as every sectioned one does: a section of a kind this decoder does not
    know is skipped (its kind goes to ``ignored``), and so is the end of a known section
    past the fields read here."""
    r = _Reader(bytes(data))
    magic = r.take(4, "magic")
    if magic != b"FWA1":
        raise ProtocolError("bad magic %r: expected b'FWA1'" % magic, field="magic", at=0)
    (t_s,) = r.unpack("d", "t_s")
    if not math.isfinite(t_s):
        raise ProtocolError("%r is not a time" % t_s, field="t_s", at=4)
    (receive_us,) = r.unpack("Q", "server_receive_us")
    (count,) = r.unpack("B", "section count")
    # The framing of every section first, then their bodies, as the Rust decoder reads them,
    # so that a message wrong in both ways is refused by the same name.
    sections = [_next_section(r, number, count, _FWA1_SECTIONS) for number in range(count)]
    if r.at != r.end:
        raise ProtocolError("%d byte(s) after the last of %d sections" % (r.end - r.at, count),
                            field="end", at=r.at)
    sound: Optional[AudioChunk] = None
    seen: Dict[int, int] = {}
    ignored: List[int] = []
    for kind, at, body in sections:
        if kind == _FWA1_PCM:
            read = _read_pcm(body, t_s, receive_us)
        elif kind == _FWA1_OPUS:
            read = _read_opus(body, t_s, receive_us)
        else:
            ignored.append(kind)
            continue
        if kind in seen:
            raise ProtocolError("section %s (kind %d) given twice, first at byte %d"
                                % (body.section, kind, seen[kind]), field="sound", at=at)
        seen[kind] = at
        if sound is not None:
            raise ProtocolError("a chunk carries one of pcm and opus, not both",
                                field="sound", at=at)
        sound = read
    if sound is None:
        raise ProtocolError("the chunk has neither a pcm nor an opus section",
                            field="sound", at=20)
    sound.ignored = ignored
    return sound


def _read_pcm(r: _Reader, t_s: float, receive_us: int) -> AudioChunk:
    """A ``pcm`` section's body: rate, count, samples; what follows is a later sender's."""
    at = r.at
    (sample_rate,) = r.unpack("I", "sample_rate")
    if sample_rate not in PCM_RATES:
        raise ProtocolError("%d Hz: expected 16000, 24000 or 48000" % sample_rate,
                            field="sample_rate", at=at)
    (count,) = r.unpack("I", "pcm count")
    raw = r.take(2 * count, "pcm")
    return AudioChunk(t_s, receive_us, "pcm", sample_rate,
                      samples=list(struct.unpack("<%dh" % count, raw)))


def _read_opus(r: _Reader, t_s: float, receive_us: int) -> AudioChunk:
    """An ``opus`` section's body: length, packet; what follows is a later sender's."""
    (length,) = r.unpack("H", "opus length")
    at = r.at
    if length > _MAX_OPUS_PACKET:
        raise ProtocolError("%d bytes: an Opus packet has at most %d" % (length, _MAX_OPUS_PACKET),
                            field="opus", at=at)
    packet = r.take(length, "opus")
    opus_packet_samples(packet, at)
    return AudioChunk(t_s, receive_us, "opus", OPUS_RATE, packet=packet)


# ---------------------------------------------------------------------------------------
# HTTP


def _base_urls(url: str) -> Tuple[str, str]:
    """(http base, ws base) of a server URL given as http(s):// or ws(s)://, no trailing /."""
    parts = urllib.parse.urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in ("http", "https", "ws", "wss") or not parts.netloc:
        raise FacewireError("server URL %r: expected http://host:port (or https, ws, wss)" % url)
    secure = scheme in ("https", "wss")
    path = parts.path.rstrip("/")
    http = urllib.parse.urlunsplit(("https" if secure else "http", parts.netloc, path, "", ""))
    ws = urllib.parse.urlunsplit(("wss" if secure else "ws", parts.netloc, path, "", ""))
    return http, ws


def _segment(text: str) -> str:
    return urllib.parse.quote(text, safe="")


class Client:
    """The HTTP side of a facewire server.

    ``url`` is the server's base URL (``http://127.0.0.1:8480``). ``token``, when the
    server is configured with tokens, goes in an ``Authorization: Bearer`` header on every
    request; calls that need another one (admin, producer) take ``token=`` themselves."""

    def __init__(self, url: str, token: Optional[str] = None, timeout: float = 30.0):
        self.url, self.ws_url = _base_urls(url)
        self.token = token
        self.timeout = timeout

    def request(self, method: str, path: str, body: Optional[bytes] = None,
                content_type: Optional[str] = None,
                token: Optional[str] = None) -> Tuple[int, bytes]:
        """One HTTP request; returns (status, body) or raises :class:`HttpError`."""
        url = self.url + path
        request = urllib.request.Request(url, data=body, method=method)
        token = token if token is not None else self.token
        if token:
            request.add_header("Authorization", "Bearer " + token)
        if content_type:
            request.add_header("Content-Type", content_type)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                return response.status, response.read()
        except urllib.error.HTTPError as e:
            raw = e.read()
            code, message = "http_%d" % e.code, raw.decode("utf-8", "replace").strip()
            try:
                parsed = json.loads(raw)
                if isinstance(parsed, dict):
                    code = str(parsed.get("error", code))
                    message = str(parsed.get("message", message))
            except ValueError:
                pass
            raise HttpError(method, url, e.code, code, message or str(e.reason)) from None
        except urllib.error.URLError as e:
            raise FacewireError("%s %s: cannot reach the server: %s" % (method, url, e.reason)) from None
        except OSError as e:
            raise FacewireError("%s %s: %s" % (method, url, e)) from None

    def _json(self, method: str, path: str, payload: Any = None,
              token: Optional[str] = None) -> Any:
        body = None if payload is None else json.dumps(payload).encode("utf-8")
        _, raw = self.request(method, path, body, "application/json" if body else None, token)
        try:
            return json.loads(raw) if raw else None
        except ValueError:
            raise ProtocolError("%s %s: the answer is not JSON: %r" % (method, path, raw[:200])) from None

    def health(self) -> Dict[str, Any]:
        """``GET /healthz``: ``{"status": "ok", "heads": N, "uptime_s": S}``."""
        return cast(Dict[str, Any], self._json("GET", "/healthz"))

    def algorithms(self) -> List[Dict[str, Any]]:
        """``GET /v1/algorithms``: presets with letter, spec, linear, description, default."""
        return cast(List[Dict[str, Any]], self._json("GET", "/v1/algorithms"))

    def list_heads(self) -> List[Dict[str, Any]]:
        """``GET /v1/heads``: head info of every registered head."""
        return cast(List[Dict[str, Any]], self._json("GET", "/v1/heads"))

    def head(self, head_id: str) -> Dict[str, Any]:
        """``GET /v1/heads/{id}``: id, vertices, triangles, mm_per_unit, status, progress,
        error, streams, algorithms."""
        return cast(Dict[str, Any], self._json("GET", "/v1/heads/" + _segment(head_id)))

    def register_head(self, head_id: str, obj: str, *, fit: Optional[str] = None,
                      landmarks: Optional[str] = None, producer_token: Optional[str] = None,
                      token: Optional[str] = None,
                      parts: Optional[Sequence[Tuple[str, str, Optional[str]]]] = None
                      ) -> Dict[str, Any]:
        """``POST /v1/heads`` with the OBJ text and exactly one of ``fit`` (a ``.fit.toml``
        text) or ``landmarks`` (a ``.landmarks.toml`` text, the server solves the fit).
        ``parts`` are the head's part meshes as ``(name, obj text, role)`` with role
        ``"skull"``, ``"jaw"``, ``"tongue"`` or ``None`` (the server infers skull or jaw).
        Registration runs in the background: follow with :meth:`wait_ready`. ``token`` is
        the admin token."""
        if (fit is None) == (landmarks is None):
            raise FacewireError("register_head: give exactly one of fit and landmarks")
        payload: Dict[str, Any] = {"id": head_id, "obj": obj}
        if parts:
            payload["parts"] = [dict({"name": name, "obj": text}, **({"role": role} if role else {}))
                                for name, text, role in parts]
        if fit is not None:
            payload["fit"] = fit
        if landmarks is not None:
            payload["landmarks"] = landmarks
        if producer_token is not None:
            payload["producer_token"] = producer_token
        return cast(Dict[str, Any], self._json("POST", "/v1/heads", payload, token))

    def register_head_files(self, head_id: str, obj_path: str, *, fit_path: Optional[str] = None,
                            landmarks_path: Optional[str] = None,
                            producer_token: Optional[str] = None,
                            token: Optional[str] = None) -> Dict[str, Any]:
        """:meth:`register_head` with the texts read from files."""

        def read(path: Optional[str]) -> Optional[str]:
            if path is None:
                return None
            with open(path, "r", encoding="utf-8") as f:
                return f.read()

        obj = read(obj_path)
        assert obj is not None
        return self.register_head(head_id, obj, fit=read(fit_path), landmarks=read(landmarks_path),
                                  producer_token=producer_token, token=token)

    def wait_ready(self, head_id: str, timeout: float = 300.0, poll_s: float = 0.1) -> Dict[str, Any]:
        """Polls ``GET /v1/heads/{id}`` until ``status`` is ``ready`` and returns the head
        info; raises :class:`FacewireError` if registration failed or took too long."""
        deadline = time.monotonic() + timeout
        while True:
            info = self.head(head_id)
            status = info.get("status")
            if status == "ready":
                return info
            if status == "failed":
                raise FacewireError("head %r failed to register: %s" % (head_id, info.get("error")))
            if time.monotonic() >= deadline:
                raise FacewireError("head %r is still %s (%.0f %%) after %.0f s"
                                    % (head_id, status, 100 * float(info.get("progress", 0)), timeout))
            time.sleep(poll_s)

    def delete_head(self, head_id: str, token: Optional[str] = None) -> None:
        """``DELETE /v1/heads/{id}`` (admin token); its streams end."""
        self.request("DELETE", "/v1/heads/" + _segment(head_id), token=token)

    def mesh(self, head_id: str) -> RestMesh:
        """``GET /v1/heads/{id}/mesh.bin``, decoded."""
        return self.mesh_at("/v1/heads/%s/mesh.bin" % _segment(head_id))

    def mesh_at(self, path: str) -> RestMesh:
        """The rest mesh at a server path (a snapshot's ``rest_mesh``, a part's
        ``mesh``), decoded."""
        _, raw = self.request("GET", path)
        return decode_mesh(raw)

    def part_mesh(self, head_id: str, name: str) -> RestMesh:
        """``GET /v1/heads/{id}/parts/{name}/mesh.bin``: a part's rest mesh, decoded
        (head units, in the head's frame). 404 ``not_found`` for a name the head has not."""
        return self.mesh_at("/v1/heads/%s/parts/%s/mesh.bin" % (_segment(head_id), _segment(name)))

    def post_batch(self, head_id: str, stream: str,
                   frames: Union[None, str, bytes, Iterable[Mapping[str, Any]]] = None, *,
                   fap: bool = False, token: Optional[str] = None,
                   audio: Union[None, str, "os.PathLike[str]", Sequence[int], bytes, bytearray] = None,
                   sample_rate: int = 16000, audio_t_s: Optional[float] = None) -> Dict[str, Any]:
        """``POST .../streams/{stream}/batch``: a whole stream, played by the server at its
        timestamps. ``frames`` is JSONL text or bytes, or frame mappings (written as
        JSONL); ``fap=True`` sends an MPEG-4 ``.fap`` file's text instead.

        ``audio`` is the stream's voice, played with the frames on their clock: a WAV
        file's path (the server takes any PCM or float WAV at 16, 24 or 48 kHz, mixed to
        mono), or 16-bit mono samples at ``sample_rate`` (integers, or ``bytes`` of
        little-endian i16). Its first sample plays at ``audio_t_s`` (by default the first
        frame's ``t``). With ``audio``, ``frames`` may be left out: a voice alone.

        Returns ``{"frames": N, "duration_s": S, "audio_s": A}``; errors name the part,
        line and field (400 ``bad_frame``). ``token`` is the producer token."""
        if frames is None and audio is None:
            raise FrameError("post_batch: give frames, audio or both")
        body: Optional[bytes] = None
        if isinstance(frames, bytes):
            body = frames
        elif isinstance(frames, str):
            body = frames.encode("utf-8")
        elif frames is not None:
            body = "".join(encode_json(f) + "\n" for f in frames).encode("utf-8")
        path = "/v1/heads/%s/streams/%s/batch" % (_segment(head_id), _segment(stream))
        stream_type = "application/x-fap" if fap else "application/x-ndjson"
        if audio is None:
            _, raw = self.request("POST", path, body, stream_type, token)
            return cast(Dict[str, Any], json.loads(raw))
        parts: List[Tuple[str, Optional[str], str, bytes]] = []
        if body is not None:
            parts.append(("stream", "stream.fap" if fap else "stream.jsonl", stream_type, body))
        if isinstance(audio, (str, os.PathLike)):
            with open(os.fspath(audio), "rb") as f:
                wav_file = f.read()
        else:
            wav_file = _wav_file(_pcm_samples(audio_t_s or 0.0, audio), sample_rate)
        parts.append(("audio", "audio.wav", "audio/wav", wav_file))
        if audio_t_s is not None:
            if (isinstance(audio_t_s, bool) or not isinstance(audio_t_s, (int, float))
                    or not math.isfinite(audio_t_s)):
                raise FrameError("post_batch: audio_t_s %r is not a finite number of seconds"
                                 % (audio_t_s,))
            parts.append(("audio_t_s", None, "text/plain", repr(float(audio_t_s)).encode("ascii")))
        content_type, form = _multipart(parts)
        _, raw = self.request("POST", path, form, content_type, token)
        return cast(Dict[str, Any], json.loads(raw))

    def producer(self, head_id: str, stream: str = "main", **options: Any) -> "Producer":
        """A :class:`Producer` on this server (options as :class:`Producer`; the token
        defaults to this client's)."""
        options.setdefault("token", self.token)
        return Producer(self.url, head_id, stream, timeout=options.pop("timeout", self.timeout),
                        **options)

    def viewer(self, head_id: str, stream: str = "main", **options: Any) -> "Viewer":
        """A :class:`Viewer` on this server (options as :class:`Viewer`)."""
        options.setdefault("token", self.token)
        return Viewer(self.url, head_id, stream, timeout=options.pop("timeout", self.timeout),
                      **options)


# ---------------------------------------------------------------------------------------
# WebSocket plumbing


#: The shortest wait of :meth:`_Socket.receive_within`, seconds: the socket layer's own
#: (it rounds up to milliseconds), so that looking for what has arrived costs a producer
#: nothing.
_READY_S = 0.001


class _Socket:
    """A websocket-client connection with close codes, timeouts and HTTP refusals turned
    into this module's errors."""

    def __init__(self, url: str, token: Optional[str], timeout: float):
        ws_module = _websocket_module()
        self._module = ws_module
        self.url = url
        self.closed: Optional[ConnectionClosed] = None
        header = ["Authorization: Bearer " + token] if token else []
        try:
            self._ws = ws_module.create_connection(url, header=header, timeout=timeout)
        except ws_module.WebSocketBadStatusException as e:
            body = e.resp_body or b""
            if isinstance(body, str):
                body = body.encode("utf-8")
            code, message = "http_%d" % e.status_code, body.decode("utf-8", "replace").strip()
            try:
                parsed = json.loads(body)
                if isinstance(parsed, dict):
                    code = str(parsed.get("error", code))
                    message = str(parsed.get("message", message))
            except ValueError:
                pass
            raise HttpError("GET", url, e.status_code, code, message or str(e)) from None
        except (OSError, ws_module.WebSocketException) as e:
            raise FacewireError("cannot connect to %s: %s" % (url, e)) from None

    def send_text(self, text: str) -> None:
        self._send(text, self._module.ABNF.OPCODE_TEXT)

    def send_binary(self, data: bytes) -> None:
        self._send(data, self._module.ABNF.OPCODE_BINARY)

    def _send(self, payload: Union[str, bytes], opcode: int) -> None:
        if self.closed is not None:
            raise self.closed
        try:
            self._ws.send(payload, opcode)
        except (OSError, self._module.WebSocketException) as e:
            self.closed = ConnectionClosed(None, "while sending: %s" % e)
            raise self.closed from None

    def receive(self, timeout: Optional[float] = None) -> Union[str, bytes]:
        """The next text (str) or binary (bytes) message. Raises :class:`ConnectionClosed`
        when the socket closes and :class:`TimeoutError` after ``timeout`` seconds."""
        if self.closed is not None:
            raise self.closed
        ws = self._module
        if timeout is not None:
            self._ws.settimeout(timeout)
        try:
            while True:
                opcode, frame = self._ws.recv_data_frame(True)
                if opcode == ws.ABNF.OPCODE_TEXT:
                    return bytes(frame.data).decode("utf-8")
                if opcode == ws.ABNF.OPCODE_BINARY:
                    return bytes(frame.data)
                if opcode == ws.ABNF.OPCODE_CLOSE:
                    data = bytes(frame.data)
                    code = struct.unpack("!H", data[:2])[0] if len(data) >= 2 else None
                    self.closed = ConnectionClosed(code, data[2:].decode("utf-8", "replace"))
                    self._ws.shutdown()  # websocket-client already answered the close
                    raise self.closed
                # ping (answered by websocket-client) and pong: keep reading
        except ws.WebSocketTimeoutException:
            raise TimeoutError("no message from %s within %s s" % (self.url, timeout)) from None
        except ws.WebSocketConnectionClosedException as e:
            self.closed = ConnectionClosed(None, str(e) or "the server went away")
            raise self.closed from None
        except OSError as e:
            if isinstance(e, TimeoutError):
                raise TimeoutError("no message from %s within %s s" % (self.url, timeout)) from None
            self.closed = ConnectionClosed(None, str(e))
            raise self.closed from None

    def receive_within(self, timeout: float) -> Optional[Union[str, bytes]]:
        """The next message if one arrives within ``timeout`` seconds, else None: for answers
        that may never come (the server answers an audio chunk only to refuse it). A message
        caught halfway is kept by websocket-client and finished by the next read. The
        socket's timeout is put back, since sends use it too."""
        previous = self._ws.gettimeout()
        try:
            return self.receive(max(timeout, _READY_S))
        except TimeoutError:
            return None
        finally:
            if self.closed is None:
                self._ws.settimeout(previous)

    def shutdown(self) -> None:
        try:
            self._ws.close(timeout=1.0)
        except Exception:  # closing is best effort: the peer may be gone already
            pass


def _server_message(text: str, url: str) -> Dict[str, Any]:
    try:
        message = json.loads(text)
    except ValueError:
        raise ProtocolError("%s sent text that is not JSON: %r" % (url, text[:200])) from None
    if not isinstance(message, dict) or "type" not in message:
        raise ProtocolError("%s sent JSON without a type: %r" % (url, text[:200]))
    return message


def _refused(message: Mapping[str, Any]) -> Refused:
    return Refused(str(message.get("code", "?")), str(message.get("message", "")),
                   message.get("seq"), message.get("field"))


# ---------------------------------------------------------------------------------------
# Producer


@dataclass
class Ack:
    """The server accepted frame ``seq`` at ``received_us`` (µs since the Unix epoch).
    ``ignored`` lists the kinds of the ``FWP2`` sections the server skipped because it does
    not know them (empty for everything else), so that a producer newer than the server
    learns what was not used."""

    seq: int
    received_us: int
    ignored: List[int] = field(default_factory=list)


@dataclass
class Derived:
    """A frame the server derived from the producer's voice (``derive="visemes"``), told to
    a producer that asked (``derived=True``): frame ``seq`` at stream time ``t`` (seconds)
    shows viseme ``viseme`` (its Oculus name, ``sil``, ``PP``, ``FF``, ... ``ou``), to which
    the model gave probability ``confidence``."""

    seq: int
    t: float
    viseme: str
    confidence: float


def _binary_layout(binary: Union[bool, str, None]) -> Optional[str]:
    """What a producer's ``binary`` option asks for: None for JSON text (False), else the
    binary layout, ``"fwp2"`` (True, the default binary layout) or ``"fwp1"`` (the frozen
    one, which every server reads)."""
    if binary is None or binary is False:
        return None
    if binary is True:
        return "fwp2"
    if binary in ("fwp2", "fwp1"):
        return cast(str, binary)
    raise FacewireError("binary=%r: expected False (JSON text), True or 'fwp2', or 'fwp1'"
                        % (binary,))


#: The codes a refused audio chunk gets (PROTOCOL.md, "Audio (FWA1)").
_AUDIO_REFUSALS = ("bad_frame", "out_of_order", "rate_limited")


def _pcm_samples(t_s: float, samples: Union[Sequence[int], bytes, bytearray]) -> Sequence[int]:
    """PCM as integers: ``bytes`` are read as little-endian i16, anything else is taken as
    a sequence of samples (checked when encoded)."""
    if isinstance(samples, (bytes, bytearray)):
        if len(samples) % 2:
            raise FrameError("audio at t %s s: %d bytes of PCM is not a whole number of "
                             "16-bit samples" % (t_s, len(samples)))
        return struct.unpack("<%dh" % (len(samples) // 2), samples)
    return samples


def _open_wav(name: str) -> "wave.Wave_read":
    """A WAV file of 16-bit mono PCM at a rate of :data:`PCM_RATES`, opened; anything else
    raises :class:`FrameError` saying what differs."""
    try:
        wav = wave.open(name, "rb")
    except (wave.Error, EOFError) as e:
        raise FrameError("%s: not a WAV file of uncompressed PCM (%s)" % (name, e)) from None
    channels, width, rate = wav.getnchannels(), wav.getsampwidth(), wav.getframerate()
    problems = []
    if channels != 1:
        problems.append("%d channels, facewire takes mono" % channels)
    if width != 2:
        problems.append("%d-bit samples, facewire takes 16-bit" % (8 * width))
    if rate not in PCM_RATES:
        problems.append("%d Hz, the protocol takes %s Hz" % (rate, ", ".join(map(str, PCM_RATES))))
    if problems:
        wav.close()
        raise FrameError("%s: %s" % (name, "; ".join(problems)))
    return wav


def _wav_file(samples: Sequence[int], sample_rate: int) -> bytes:
    """16-bit mono ``samples`` at ``sample_rate`` as the bytes of a WAV file."""
    if sample_rate not in PCM_RATES:
        raise FrameError("audio: PCM at %r Hz; the protocol takes %s"
                         % (sample_rate, ", ".join(map(str, PCM_RATES))))
    out = io.BytesIO()
    with wave.open(out, "wb") as wav:
        wav.setnchannels(1)
        wav.setsampwidth(2)
        wav.setframerate(sample_rate)
        try:
            data = array("h", samples)
        except (OverflowError, TypeError) as e:
            raise FrameError("audio: samples must be 16-bit integers (%s)" % e) from None
        if sys.byteorder == "big":
            data.byteswap()
        wav.writeframes(data.tobytes())
    return out.getvalue()


def _multipart(parts: Sequence[Tuple[str, Optional[str], str, bytes]]) -> Tuple[str, bytes]:
    """A ``multipart/form-data`` body of ``(name, file name, content type, bytes)`` parts,
    and its content type."""
    boundary = "facewire-" + os.urandom(16).hex()
    out = bytearray()
    for name, file_name, content_type, data in parts:
        disposition = 'form-data; name="%s"' % name
        if file_name:
            disposition += '; filename="%s"' % file_name
        out += ("--%s\r\nContent-Disposition: %s\r\nContent-Type: %s\r\n\r\n"
                % (boundary, disposition, content_type)).encode("ascii")
        out += data + b"\r\n"
    out += ("--%s--\r\n" % boundary).encode("ascii")
    return "multipart/form-data; boundary=" + boundary, bytes(out)


def _read_wav(name: str) -> Tuple[int, List[int]]:
    """A whole WAV file (as :func:`_open_wav` takes it): its rate and samples."""
    with _open_wav(name) as wav:
        raw = wav.readframes(wav.getnframes())
        raw = raw[:len(raw) - len(raw) % 2]
        # wave gives samples in the machine's byte order, which array reads.
        return wav.getframerate(), array("h", raw).tolist()


def _pcm_chunks(t_s: float, samples: Sequence[int], sample_rate: int) -> List[AudioChunk]:
    """PCM cut into :data:`AUDIO_CHUNK_S` chunks, the one starting at sample ``i`` at
    ``t_s + i / sample_rate``."""
    if isinstance(t_s, bool) or not isinstance(t_s, (int, float)) or not math.isfinite(t_s):
        raise FrameError("audio: t_s %r is not a finite number of seconds" % (t_s,))
    if sample_rate not in PCM_RATES:
        raise FrameError("audio at t %s s: PCM at %r Hz; the protocol takes %s"
                         % (t_s, sample_rate, ", ".join(map(str, PCM_RATES))))
    per = round(sample_rate * AUDIO_CHUNK_S)
    return [AudioChunk(t_s + i / sample_rate, 0, "pcm", sample_rate, list(samples[i:i + per]))
            for i in range(0, len(samples), per)]


class Producer:
    """Pushes frames to ``/v1/heads/{head}/streams/{stream}/produce``.

    ``url`` is the server's base URL; ``token`` the producer token (sent as
    ``Authorization: Bearer``). ``binary`` says how :meth:`send` encodes frames: False
    for JSON text, True or ``"fwp2"`` for binary ``FWP2``, ``"fwp1"`` for the frozen
    ``FWP1`` (for servers before ``FWP2``). Each :meth:`send` waits for the server's answer: it
    returns an :class:`Ack` or raises :class:`Refused` (the stream keeps running after a
    refused frame). Limits respected before sending: a message longer than
    ``max_message_bytes`` is refused locally (:class:`FrameError`), and frames are spaced
    at least ``1 / max_fps`` seconds apart (set both to the server's configuration when it
    differs from the defaults, 64 KiB and 240 fps). Frames must have increasing ``seq``
    and non-decreasing ``t``.

    As a context manager it sends ``{"type":"end"}`` on a normal exit (viewers get
    ``end``), then raises :class:`AudioRefused` for audio refusals not raised yet, and
    closes the socket either way::

        with Producer("http://127.0.0.1:8480", "scan", "main") as producer:
            producer.send({"seq": 0, "t": 0.0, "label": "pa", "au": {"jaw_drop": 0.3}})
            producer.send_wav("pa.wav", t_s=0.0)

    **Audio.** :meth:`send_audio` (PCM samples), :meth:`send_opus` (an Opus packet) and
    :meth:`send_wav` (a WAV file) send the stream's voice as ``FWA1`` chunks on the same
    socket, with or without frames, on the frames' clock. The server answers an audio chunk
    only when it refuses it, so they do not wait for answers. The producer reads refusals
    whenever it reads the socket: after each chunk it sends (taking only what has arrived)
    and while :meth:`send` or :meth:`end` waits for its answer. It tells them from a frame's
    answer by order (the server answers every message before it reads the next, so what
    comes before a frame's answer is about what was sent before the frame) and by ``seq``
    (a frame's answer names it; an audio refusal names none). A refusal surfaces as an
    :class:`AudioRefused`, which is a :class:`Refused`:

    - from the next :meth:`send_audio` or :meth:`send_opus`, before it sends anything: the
      call had no effect and may be made again;
    - from :meth:`send_wav` as soon as one is read, which stops it (as :meth:`play` stops at
      a refused frame);
    - from :meth:`check_audio`, which reads what has arrived, or arrives within a timeout;
    - on leaving the ``with`` block normally: the server answers ``end`` after every message
      before it, so no refusal is left unread then.

    **A face from the voice alone.** ``derive="visemes"`` asks the server to derive the face
    from the audio (PROTOCOL.md, "A face derived from the voice"): send audio only (a
    parameter frame is refused with field ``derive``), at ``fps`` frames a second (the
    server's 30 by default). With ``derived=True`` the server tells the producer each frame
    it derives; they are kept, in order, in :attr:`derived` (:class:`Derived`) as the
    producer reads the socket, and :meth:`end` reads the last of them::

        with Producer(url, "scan", "talk", derive="visemes", derived=True) as producer:
            producer.send_wav("hello.wav")
            producer.end()
            print([d.viseme for d in producer.derived])

    :meth:`send` never raises one: it returns its frame's :class:`Ack`, and keeps the
    refusals it read for those. (A frame that :meth:`send_encoded` sends in a form the
    server cannot read a ``seq`` from, right after audio, would be taken for audio's
    refusal, and its own answer waited for until ``timeout``: send such test frames apart
    from audio. Frames :meth:`send` encodes always have a readable ``seq``.)
    """

    def __init__(self, url: str, head: str, stream: str = "main", *, token: Optional[str] = None,
                 binary: Union[bool, str] = False, timeout: float = 10.0,
                 max_fps: float = DEFAULT_MAX_FPS,
                 max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
                 derive: Optional[str] = None, fps: Optional[float] = None,
                 derived: bool = False):
        _, ws_base = _base_urls(url)
        self.url = "%s/v1/heads/%s/streams/%s/produce" % (ws_base, _segment(head), _segment(stream))
        query: Dict[str, str] = {}
        if derive is not None:
            query["derive"] = derive
            if fps is not None:
                query["fps"] = repr(float(fps))
            if derived:
                query["derived"] = "1"
        elif fps is not None or derived:
            raise FrameError("fps= and derived= go with derive='visemes'")
        if query:
            self.url += "?" + urllib.parse.urlencode(query)
        #: The frames the server derived from the voice, as read (``derived=True``).
        self.derived: List[Derived] = []
        #: None (JSON text), ``"fwp2"`` or ``"fwp1"``: how :meth:`send` encodes by default.
        self.binary = _binary_layout(binary)
        self.timeout = timeout
        self.min_interval_s = 1.0 / max_fps if max_fps and max_fps > 0 else 0.0
        self.max_message_bytes = max_message_bytes
        self.ended = False
        self._last_send: Optional[float] = None
        #: Audio chunks sent since the server last answered a frame or ``end``: as many
        #: refusals naming no ``seq`` may still come for them.
        self._audio_unanswered = 0
        #: Audio refusals read and not raised yet, oldest first.
        self._audio_refusals: List[Refused] = []
        #: When the first audio chunk went out (monotonic seconds) and its ``t_s``: the
        #: server measures how far audio runs ahead of real time from there, and paced
        #: chunks keep to the same clock.
        self._audio_start: Optional[Tuple[float, float]] = None
        self._socket = _Socket(self.url, token, timeout)

    def __enter__(self) -> "Producer":
        return self

    def __exit__(self, kind: Any, value: Any, traceback: Any) -> None:
        try:
            if kind is None and not self.ended and self._socket.closed is None:
                self.end()
            if kind is None:
                self.check_audio()
        finally:
            self.close()

    def send(self, frame: Mapping[str, Any], *, binary: Union[bool, str, None] = None) -> Ack:
        """Sends one frame (a JSONL object) as JSON text, ``FWP2`` or ``FWP1`` as ``binary``
        says (default: the producer's ``binary``; values as :class:`Producer`'s), and
        returns the server's :class:`Ack`."""
        layout = self.binary if binary is None else _binary_layout(binary)
        payload: Union[str, bytes]
        if layout == "fwp2":
            payload = encode_fwp2(frame)
        elif layout == "fwp1":
            payload = encode_fwp1(frame)
        else:
            payload = encode_json(frame)
        return self.send_encoded(payload, _frame_seq(frame))

    def send_encoded(self, payload: Union[str, bytes], seq: int) -> Ack:
        """Sends one frame already encoded, JSON text (str) or a binary message (bytes), and
        returns the server's :class:`Ack` for it; ``seq`` is the frame's, which the answer
        must name. For messages this module does not write itself, such as an ``FWP2``
        frame with sections from a later protocol (the ack's ``ignored`` then lists those
        the server skipped). The same limits and pacing as :meth:`send`."""
        size = len(payload) if isinstance(payload, bytes) else len(payload.encode("utf-8"))
        if size > self.max_message_bytes:
            raise FrameError("frame seq %d is %d bytes; the server takes at most %d "
                             "(max_message_bytes)" % (seq, size, self.max_message_bytes))
        self._pace()
        if isinstance(payload, bytes):
            self._socket.send_binary(payload)
        else:
            self._socket.send_text(payload)
        message = self._answer()
        kind = message.get("type")
        if kind == "ack":
            ignored = message.get("ignored", [])
            if not isinstance(ignored, list) or not all(
                    isinstance(k, int) and not isinstance(k, bool) for k in ignored):
                raise ProtocolError("ack for seq %d: ignored is not a list of section kinds: %r"
                                    % (seq, ignored), field="ignored")
            ack = Ack(int(message["seq"]), int(message["received_us"]), ignored)
            if ack.seq != seq:
                raise ProtocolError("sent seq %d, the server acknowledged seq %d" % (seq, ack.seq))
            return ack
        if kind == "error":
            refused = _refused(message)
            if refused.seq is None and refused.code not in ("producer_busy", "idle"):
                # bad_frame and message_too_large name no seq: it is the frame just sent
                refused = Refused(refused.code, refused.message, seq, refused.field)
            raise refused
        raise ProtocolError("expected an ack or error for seq %d, got %r" % (seq, message))

    def play(self, frames: Iterable[Mapping[str, Any]], *, realtime: bool = True,
             speed: float = 1.0,
             audio: Union[None, str, "os.PathLike[str]", Sequence[int], bytes, bytearray] = None,
             sample_rate: int = 16000, audio_t_s: Optional[float] = None) -> List[Ack]:
        """Sends every frame, at its ``t`` (relative to the first, divided by ``speed``)
        when ``realtime``, else as fast as the acks and ``max_fps`` allow. Stops at the
        first refusal (raises :class:`Refused`). Does not end the stream.

        ``audio`` is the frames' voice, sent with them on their clock: a WAV file's path
        (16-bit mono PCM, as :meth:`send_wav` takes) or samples (as :meth:`send_audio`
        takes, at ``sample_rate``), whose first sample plays at ``audio_t_s`` (by default
        the first frame's ``t``). Each 20 ms chunk goes when its time comes, between the
        frames, so ``audio`` needs ``realtime`` at ``speed`` 1; an audio refusal raises
        :class:`AudioRefused` and stops the playback."""
        frames = list(frames)
        if audio is not None and (not realtime or speed != 1.0):
            raise FrameError("play: audio is sent in real time; use realtime=True and speed=1")
        timeline: List[Tuple[float, int, Any]] = []
        for frame in frames:
            timeline.append((_number(_frame_seq(frame), "t", frame.get("t")), 0, frame))
        if audio is not None:
            first_t = timeline[0][0] if timeline else 0.0
            audio_t = first_t if audio_t_s is None else audio_t_s
            if isinstance(audio, (str, os.PathLike)):
                rate, pcm = _read_wav(os.fspath(audio))
            else:
                rate, pcm = sample_rate, _pcm_samples(audio_t, audio)
            for chunk in _pcm_chunks(audio_t, pcm, rate):
                timeline.append((chunk.t_s, 1, self._audio_message(chunk)[1]))
            timeline.sort(key=lambda event: (event[0], event[1]))
        self.check_audio()
        acks: List[Ack] = []
        start: Optional[float] = None
        first = 0.0
        for t, kind, item in timeline:
            if realtime:
                if start is None:
                    start, first = time.monotonic(), t
                wait = start + (t - first) / speed - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
            if kind == 0:
                acks.append(self.send(item))
            else:
                self._send_audio_message(t, item, False)
                self._raise_audio_refusals()
        return acks

    def send_audio(self, t_s: float, samples: Union[Sequence[int], bytes, bytearray],
                   sample_rate: int = 16000, *, realtime: bool = False) -> float:
        """Sends 16-bit mono PCM whose first sample plays at stream time ``t_s`` (seconds, the
        frames' clock), cut into chunks of :data:`AUDIO_CHUNK_S` (20 ms) at consecutive
        times: the chunk starting at sample ``i`` has ``t_s + i / sample_rate`` (the last
        may be shorter). ``samples`` are integers (a list, an ``array('h')``, ...) or
        ``bytes`` of little-endian i16; ``sample_rate`` is 16000, 24000 or 48000 Hz, the same
        over a stream (the server refuses a change with field ``sound``).

        Returns the stream time just past the last sample, where the next audio starts:
        ``t = producer.send_audio(t, block)`` in a capture loop leaves neither gap nor
        overlap (the server refuses a chunk that starts before the previous one ends).

        It does not wait for answers (see :class:`Producer`): before sending anything it
        raises :class:`AudioRefused` for chunks refused earlier. The server refuses audio
        more than 2 s ahead of real time since the stream's first chunk: a live capture
        keeps to that by itself; for recorded audio pass ``realtime=True``, which sends each
        chunk when its time comes on that clock (its ``t_s`` after the first chunk's, in
        real time). Raises :class:`FrameError`, having sent nothing, for a ``t_s`` that is
        not finite, a rate not in :data:`PCM_RATES`, samples that are not 16-bit integers,
        or an odd number of bytes."""
        pcm = _pcm_samples(t_s, samples)
        messages = [self._audio_message(chunk) for chunk in _pcm_chunks(t_s, pcm, sample_rate)]
        self.check_audio()
        for chunk_t, message in messages:
            self._send_audio_message(chunk_t, message, realtime)
        return t_s + len(pcm) / sample_rate

    def send_opus(self, t_s: float, packet: bytes, *, realtime: bool = False) -> float:
        """Sends one Opus packet (RFC 6716, mono, as an encoder or WebRTC gives it; 20 ms is
        usual, 2.5 to 120 ms allowed) whose sound starts at stream time ``t_s``, and returns
        the time just past it (its table of contents says how long it plays:
        :func:`opus_packet_samples`). Answers, refusals and ``realtime`` as
        :meth:`send_audio`. Raises :class:`FrameError`, having sent nothing, for a packet
        over 1275 bytes or whose table of contents does not parse."""
        chunk = AudioChunk(t_s, 0, "opus", OPUS_RATE, packet=bytes(packet))
        chunk_t, message = self._audio_message(chunk)
        self.check_audio()
        self._send_audio_message(chunk_t, message, realtime)
        return t_s + chunk.duration_s

    def send_wav(self, path: Union[str, "os.PathLike[str]"], t_s: float = 0.0,
                 realtime: bool = True) -> float:
        """Sends a WAV file's sound from stream time ``t_s`` in 20 ms chunks, as
        :meth:`send_audio` sends samples, read a chunk at a time (a long file is never held
        whole). The file must be uncompressed 16-bit PCM, mono, at 16000, 24000 or 48000 Hz,
        read with the standard ``wave`` module: anything else raises :class:`FrameError`
        saying what differs, before anything is sent (convert first, e.g. ``ffmpeg -i in
        -ac 1 -ar 16000 -sample_fmt s16 out.wav``).

        With ``realtime`` (the default) it sends at the sound's own pace, which the server
        requires of audio beyond its 2 s lead, so it returns about when the sound ends;
        ``realtime=False`` sends as fast as the socket takes it, for files of at most 2 s.
        It stops at the first refusal it reads and raises :class:`AudioRefused` (the rest
        of the file is not sent). Returns the stream time just past the last sample."""
        with _open_wav(os.fspath(path)) as wav:
            rate = wav.getframerate()
            per = round(rate * AUDIO_CHUNK_S)
            self.check_audio()
            sent = 0
            while True:
                raw = wav.readframes(per)
                raw = raw[:len(raw) - len(raw) % 2]  # a file cut inside its last sample
                if not raw:
                    return t_s + sent / rate
                chunk_t = t_s + sent / rate
                # wave gives samples in the machine's byte order, which array reads.
                samples = array("h", raw).tolist()
                _, message = self._audio_message(AudioChunk(chunk_t, 0, "pcm", rate, samples))
                self._send_audio_message(chunk_t, message, realtime)  # reads what came
                self._raise_audio_refusals()
                sent += len(samples)

    def check_audio(self, timeout: float = 0.0) -> None:
        """Raises :class:`AudioRefused` for the audio refusals read and not raised yet,
        reading first what has arrived, and what arrives within ``timeout`` seconds; returns
        when there are none. A refusal takes the server a round trip: to learn of the last
        chunks' fate without sending more, wait a little (``check_audio(0.2)``), or send a
        frame (everything before its answer has been answered) or end the stream."""
        if not self.ended and self._socket.closed is None:
            self._read_audio_answers(timeout)
        self._raise_audio_refusals()

    def end(self) -> "StreamEnd":
        """Sends ``{"type":"end"}``: viewers get ``end`` after the last frame sent. The
        server answers ``end`` (returned) and closes the socket with code 1000; connect
        again to start a new run of frames. Audio refusals read on the way are kept for
        :meth:`check_audio` (which leaving the ``with`` block calls)."""
        self._socket.send_text('{"type":"end"}')
        self.ended = True
        while True:
            parsed = self._answer()
            if parsed.get("type") == "end":
                try:
                    self._socket.receive(self.timeout)
                except ConnectionClosed:
                    pass
                return StreamEnd(str(parsed.get("reason", "")), str(parsed.get("message", "")))

    def close(self) -> None:
        """Closes the socket (without ending the stream if :meth:`end` was not called)."""
        self._socket.shutdown()

    def _pace(self) -> None:
        now = time.monotonic()
        if self._last_send is not None:
            wait = self._last_send + self.min_interval_s - now
            if wait > 0:
                time.sleep(wait)
                now += wait
        self._last_send = now

    def _answer(self) -> Dict[str, Any]:
        """The server's answer to the frame or ``end`` just sent. Audio refusals come before
        it (the server answers in order) and are kept; once it has come, every audio chunk
        sent before has been answered."""
        while True:
            message = self._message(self._socket.receive(self.timeout))
            if self._keep_derived(message):
                continue
            if not self._keep_audio_refusal(message):
                self._audio_unanswered = 0
                return message

    def _message(self, message: Union[str, bytes]) -> Dict[str, Any]:
        if isinstance(message, bytes):
            raise ProtocolError("a producer socket got a binary message (%d bytes)" % len(message))
        return _server_message(message, self.url)

    def _keep_derived(self, message: Mapping[str, Any]) -> bool:
        """Keeps ``message`` in :attr:`derived` if it tells of a derived frame."""
        if message.get("type") != "derived":
            return False
        try:
            self.derived.append(Derived(int(message["seq"]), float(message["t"]),
                                        str(message["viseme"]["oculus"]),
                                        float(message["confidence"])))
        except (KeyError, TypeError, ValueError) as e:
            raise ProtocolError("a derived frame without %s: %r" % (e, message), field="derived")
        return True

    def _keep_audio_refusal(self, message: Mapping[str, Any]) -> bool:
        """Keeps ``message`` if it refuses an audio chunk: an ``error`` naming no ``seq``
        with a code audio is refused with, while a chunk sent since the last answer may
        still be answered. A frame's refusal names its ``seq``; ``idle`` and
        ``producer_busy`` end the session whatever was sent."""
        if (self._audio_unanswered and message.get("type") == "error"
                and message.get("seq") is None and message.get("code") in _AUDIO_REFUSALS):
            self._audio_unanswered -= 1
            self._audio_refusals.append(_refused(message))
            return True
        return False

    def _read_audio_answers(self, timeout: float) -> None:
        """Reads what arrives within ``timeout`` seconds (what has arrived already, for 0),
        when no frame waits for its answer: audio refusals, kept, or an ``error`` that ends
        the session (``idle``, ...), raised as :class:`Refused`."""
        deadline = time.monotonic() + timeout
        while True:
            arrived = self._socket.receive_within(deadline - time.monotonic())
            if arrived is None:
                return
            message = self._message(arrived)
            if self._keep_derived(message) or self._keep_audio_refusal(message):
                continue
            if message.get("type") == "error":
                raise _refused(message)
            raise ProtocolError("expected nothing or an audio refusal, got %r" % message)

    def _raise_audio_refusals(self) -> None:
        """Raises :class:`AudioRefused` for the refusals read and not raised yet."""
        if self._audio_refusals:
            refusals, self._audio_refusals = self._audio_refusals, []
            raise AudioRefused(refusals)

    def _audio_message(self, chunk: AudioChunk) -> Tuple[float, bytes]:
        """A chunk encoded and checked against ``max_message_bytes``: ``(t_s, message)``."""
        message = encode_fwa1(chunk)
        if len(message) > self.max_message_bytes:
            raise FrameError("audio at t %s s is %d bytes; the server takes at most %d "
                             "(max_message_bytes)"
                             % (chunk.t_s, len(message), self.max_message_bytes))
        return chunk.t_s, message

    def _send_audio_message(self, t_s: float, message: bytes, realtime: bool) -> None:
        """Sends one encoded chunk, when its time comes if ``realtime``, then reads what has
        arrived (so that refusals are known early and never pile up unread)."""
        if realtime and self._audio_start is not None:
            started, first_t = self._audio_start
            wait = started + (t_s - first_t) - time.monotonic()
            if wait > 0:
                time.sleep(wait)
        self._socket.send_binary(message)
        if self._audio_start is None:
            self._audio_start = (time.monotonic(), t_s)
        self._audio_unanswered += 1
        self._read_audio_answers(0.0)


# ---------------------------------------------------------------------------------------
# Viewer


@dataclass
class PartInfo:
    """A part of a head (teeth, gums, tongue), as the snapshot and head info list it:
    ``role`` is ``skull`` (moves with the head), ``jaw`` (with the jaw) or ``tongue`` (with
    the jaw, shaped by the frames' tongue deltas); ``mesh`` is the server path of its rest
    mesh (``mesh.bin`` format, :meth:`Client.mesh_at`)."""

    name: str
    role: str
    vertices: int
    triangles: int
    mesh: str

    @staticmethod
    def from_message(message: Mapping[str, Any]) -> "PartInfo":
        try:
            return PartInfo(
                name=str(message["name"]),
                role=str(message["role"]),
                vertices=int(message["vertices"]),
                triangles=int(message["triangles"]),
                mesh=str(message["mesh"]),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise ProtocolError("malformed part (%s): %r" % (e, message), field="parts") from None


@dataclass
class SectionInfo:
    """A section kind the server may put in a viewer's ``FWF2`` frames, as the snapshot's
    ``sections`` lists it: its number and name."""

    kind: int
    name: str


@dataclass
class Snapshot:
    """The first message on a viewer socket: what to download and how to decode.
    ``parts`` lists the head's parts in the order frames index them (empty for a head
    without parts). ``format`` is the frames' layout (``fwf2`` or ``fwf1``; a server
    before ``FWF2`` names none and sends ``fwf1``), ``messages`` the kinds of message that
    may follow the snapshot (empty when the server does not say; ``audio`` among them for a
    viewer that asked for audio), ``sections`` every section kind the server may put in
    ``fwf2`` frames (empty for ``fwf1``), and ``audio`` the codec of the audio chunks that
    come between the frames (``pcm`` or ``opus``; None when the viewer asked for none, or
    the server is older than audio)."""

    protocol: str
    head: str
    stream: str
    algorithm: str
    vertices: int
    triangles: int
    rest_mesh: str
    rest_obj: str
    mm_per_unit: float
    step: float
    lip_vertices: List[int]
    face_roughness: bool
    parts: List[PartInfo] = field(default_factory=list)
    format: str = "fwf1"
    messages: List[str] = field(default_factory=list)
    sections: List[SectionInfo] = field(default_factory=list)
    audio: Optional[str] = None

    @staticmethod
    def from_message(message: Mapping[str, Any]) -> "Snapshot":
        parts = message.get("parts") or []
        if not isinstance(parts, list):
            raise ProtocolError("malformed snapshot: parts is not a list: %r" % (parts,),
                                field="parts")
        sections = message.get("sections") or []
        if not isinstance(sections, list) or not all(
                isinstance(x, dict) and isinstance(x.get("kind"), int)
                and isinstance(x.get("name"), str) for x in sections):
            raise ProtocolError("malformed snapshot: sections is not a list of {kind, name}: %r"
                                % (sections,), field="sections")
        messages = message.get("messages") or []
        if not isinstance(messages, list) or not all(isinstance(x, str) for x in messages):
            raise ProtocolError("malformed snapshot: messages is not a list of names: %r"
                                % (messages,), field="messages")
        audio = message.get("audio")
        if audio is not None and not isinstance(audio, str):
            raise ProtocolError("malformed snapshot: audio is not a codec's name: %r" % (audio,),
                                field="audio")
        try:
            return Snapshot(
                protocol=str(message["protocol"]),
                head=str(message["head"]),
                stream=str(message["stream"]),
                algorithm=str(message["algorithm"]),
                vertices=int(message["vertices"]),
                triangles=int(message["triangles"]),
                rest_mesh=str(message["rest_mesh"]),
                rest_obj=str(message["rest_obj"]),
                mm_per_unit=float(message["mm_per_unit"]),
                step=float(message["step"]),
                lip_vertices=[int(v) for v in message["lip_vertices"]],
                face_roughness=bool(message["face_roughness"]),
                parts=[PartInfo.from_message(part) for part in parts],
                format=str(message.get("format", "fwf1")),
                messages=list(messages),
                sections=[SectionInfo(x["kind"], x["name"]) for x in sections],
                audio=audio,
            )
        except (KeyError, TypeError, ValueError) as e:
            raise ProtocolError("malformed snapshot (%s): %r" % (e, dict(message))) from None


@dataclass
class StreamEnd:
    """The stream ended. ``reason`` is a code (``producer_ended``, ``batch_finished``,
    ``producer_disconnected``, ``producer_idle``, ``producer_cancelled``, ``head_deleted``,
    ``server_shutdown``); ``message`` says it for people. A viewer's socket stays open for
    the stream's next producer, except when the head was deleted (close 4410) or the
    server shuts down (close 1001)."""

    reason: str
    message: str = ""


@dataclass
class ServerError:
    """An ``error`` message on a viewer socket (a close follows)."""

    code: str
    message: str
    seq: Optional[int] = None
    field: Optional[str] = None


ViewerEvent = Union[ViewerFrame, AudioChunk, StreamEnd, ServerError]


def _check_layout(snapshot: Snapshot) -> None:
    """Refuses, before the first frame, a snapshot whose frames this client cannot read:
    a layout other than the two it decodes, or a section kind it knows listed under another
    name (the server and this client would disagree on what the kind's bytes mean).
    Unknown kinds are fine: :func:`decode_fwf2` skips them."""
    if snapshot.format not in ("fwf2", "fwf1"):
        raise ProtocolError("the snapshot announces %r frames; this client reads fwf2 and fwf1"
                            % snapshot.format, field="format")
    for section in snapshot.sections:
        known = _FWF2_SECTIONS.get(section.kind)
        if known is not None and known != section.name:
            raise ProtocolError("the snapshot names section kind %d %r; this client reads it "
                                "as %r" % (section.kind, section.name, known), field="sections")


class Viewer:
    """Watches ``/v1/heads/{head}/streams/{stream}/view``.

    Connecting reads the snapshot (raises :class:`Refused` for ``unknown_head``,
    ``bad_algorithm``, ``registration_failed``, ``server_full``) and, unless
    ``fetch_mesh=False``, downloads the rest mesh over HTTP. Then :meth:`events` (or
    iterating the viewer) yields a :class:`ViewerFrame` per binary frame, with
    ``positions`` filled from the rest mesh, a :class:`StreamEnd` per ``end`` and a
    :class:`ServerError` per ``error``; it stops when the server closes the socket
    (``close_code`` says why). ``algo`` is a spec or preset letter (the server's default
    when None); ``face=True`` asks for per-vertex face roughness. ``frame_format`` is the
    layout asked for, ``"fwf2"`` (sectioned, the default) or ``"fwf1"`` (the frozen
    layout); frames of either are decoded (:func:`decode_viewer_frame`), and connecting
    checks that the snapshot names a layout this client reads and no section kind by
    another name than this client's. ``fetch_parts=True`` also
    downloads the rest meshes of the snapshot's parts into ``parts`` (in its order), which
    :meth:`place_parts` places for a frame. A viewer that reads slowly skips to the newest
    frame: the server never queues a backlog.

    ``audio="pcm"`` or ``"opus"`` asks for the stream's audio in that codec: the chunks a
    producer sends in it come as :class:`AudioChunk` events (``FWA1``, decoded by
    :func:`decode_fwa1`) between the frames, in order, each as soon as the server has it.
    Connecting then checks that the snapshot's ``audio`` names that codec (a server older
    than audio names none: :class:`ProtocolError`, field ``audio``). The server does not
    re-encode: a producer sending the other codec is not heard. Audio is never skipped for a
    viewer that keeps up; one that falls more than 64 chunks (1.3 s) behind is moved on to
    the newest, which leaves a gap in ``t_s``."""

    def __init__(self, url: str, head: str, stream: str = "main", *, algo: Optional[str] = None,
                 face: bool = False, token: Optional[str] = None, timeout: float = 30.0,
                 fetch_mesh: bool = True, fetch_parts: bool = False,
                 frame_format: str = "fwf2", audio: Optional[str] = None):
        if frame_format not in ("fwf2", "fwf1"):
            raise FacewireError("frame_format=%r: expected 'fwf2' or 'fwf1'" % (frame_format,))
        if audio not in (None, "pcm", "opus"):
            raise FacewireError("audio=%r: expected None, 'pcm' or 'opus'" % (audio,))
        http_base, ws_base = _base_urls(url)
        query = {}
        if algo:
            query["algo"] = algo
        if face:
            query["face"] = "1"
        query["format"] = frame_format
        if audio is not None:
            query["audio"] = audio
        #: The audio codec asked for, None for none.
        self.audio = audio
        self.url = "%s/v1/heads/%s/streams/%s/view" % (ws_base, _segment(head), _segment(stream))
        if query:
            self.url += "?" + urllib.parse.urlencode(query)
        self.timeout = timeout
        self.close_code: Optional[int] = None
        self._socket = _Socket(self.url, token, timeout)
        try:
            first = self._socket.receive(timeout)
            if isinstance(first, bytes):
                raise ProtocolError("expected a snapshot first, got a binary message")
            message = _server_message(first, self.url)
            if message["type"] == "error":
                raise _refused(message)
            if message["type"] != "snapshot":
                raise ProtocolError("expected a snapshot first, got %r" % message)
            self.snapshot = Snapshot.from_message(message)
            _check_layout(self.snapshot)
            if self.snapshot.audio != audio:
                raise ProtocolError("asked for audio %s, the snapshot announces %s"
                                    % (audio or "none", self.snapshot.audio or "none"),
                                    field="audio")
            self.rest: Optional[RestMesh] = None
            self.parts: List[RestMesh] = []
            client = Client(http_base, token, timeout)
            if fetch_mesh:
                self.rest = client.mesh_at(self.snapshot.rest_mesh)
                if len(self.rest.positions) != self.snapshot.vertices:
                    raise ProtocolError("the snapshot says %d vertices, mesh.bin has %d"
                                        % (self.snapshot.vertices, len(self.rest.positions)))
            if fetch_parts:
                for part in self.snapshot.parts:
                    mesh = client.mesh_at(part.mesh)
                    if len(mesh.positions) != part.vertices:
                        raise ProtocolError("the snapshot says part %s has %d vertices, its "
                                            "mesh.bin has %d"
                                            % (part.name, part.vertices, len(mesh.positions)))
                    self.parts.append(mesh)
        except BaseException:
            self._socket.shutdown()
            raise

    def __enter__(self) -> "Viewer":
        return self

    def __exit__(self, kind: Any, value: Any, traceback: Any) -> None:
        self.close()

    def __iter__(self) -> Iterator[ViewerEvent]:
        return self.events()

    def recv(self, timeout: Optional[float] = None) -> Optional[ViewerEvent]:
        """The next event (a :class:`ViewerFrame`, an :class:`AudioChunk` for a viewer that
        asked for audio, a :class:`StreamEnd` or a :class:`ServerError`), or None once the
        server has closed the socket. Raises :class:`TimeoutError` when nothing arrives
        within ``timeout`` seconds (default: the viewer's ``timeout``)."""
        try:
            message = self._socket.receive(self.timeout if timeout is None else timeout)
        except ConnectionClosed as closed:
            self.close_code = closed.code
            return None
        if isinstance(message, bytes):
            if message[:4] == b"FWA1":
                chunk = decode_fwa1(message)
                if chunk.codec != self.audio:
                    raise ProtocolError("the server sent %s audio to a viewer that asked for %s"
                                        % (chunk.codec, self.audio or "none"), field="audio")
                return chunk
            frame = decode_viewer_frame(message)
            if self.rest is not None:
                frame.positions = frame.apply(self.rest.positions)
            return frame
        parsed = _server_message(message, self.url)
        if parsed["type"] == "end":
            return StreamEnd(str(parsed.get("reason", "")), str(parsed.get("message", "")))
        if parsed["type"] == "error":
            return ServerError(str(parsed.get("code", "?")), str(parsed.get("message", "")),
                               parsed.get("seq"), parsed.get("field"))
        raise ProtocolError("unexpected message on a viewer socket: %r" % parsed)

    def place_parts(self, frame: ViewerFrame) -> List[List[Tuple[float, float, float]]]:
        """Every part where ``frame`` puts it (:meth:`ViewerFrame.place_part`), in the
        snapshot's order; needs ``fetch_parts=True``."""
        if len(self.parts) != len(self.snapshot.parts):
            raise FacewireError("the viewer has not downloaded its parts' meshes: "
                                "connect with fetch_parts=True")
        return [frame.place_part(i, info.role, mesh.positions)
                for i, (info, mesh) in enumerate(zip(self.snapshot.parts, self.parts))]

    def events(self, timeout: Optional[float] = None) -> Iterator[ViewerEvent]:
        """Every event until the server closes the socket (see :meth:`recv`)."""
        while True:
            event = self.recv(timeout)
            if event is None:
                return
            yield event

    def close(self) -> None:
        """Closes the socket."""
        self._socket.shutdown()


# ---------------------------------------------------------------------------------------
# Command line


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
        "register", help="register a head (OBJ plus fit or landmarks) and wait until ready")
    register.add_argument("--id", required=True, help="head id: 1-64 of a-z 0-9 - _")
    register.add_argument("--obj", required=True, help="OBJ file")
    fit = register.add_mutually_exclusive_group(required=True)
    fit.add_argument("--fit", help=".fit.toml file")
    fit.add_argument("--landmarks", help=".landmarks.toml file (the server solves the fit)")
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

