"""Producer frames: JSON text and binary ``FWP2`` and the frozen ``FWP1``; facewire JSONL files."""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

from .errors import FrameError
from .names import OCULUS_VISEMES, _FRAME_KEYS, _JSON_ONLY_KEYS, _U64_MAX, animation_unit_index, arkit_index, fap_number


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
