"""Viewer frames (sectioned ``FWF2``, the frozen ``FWF1``) and the rest mesh (``FWM1``), decoded."""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

from .errors import ProtocolError


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
