"""A viewer: the snapshot, the rest mesh and every frame of
``/v1/heads/{id}/streams/{stream}/view``, with the stream's audio if asked for."""

from __future__ import annotations

import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass, field
from typing import Any, Iterator, List, Mapping, Optional, Tuple, Union

from ._socket import _Socket, _base_urls, _refused, _segment, _server_message
from .audio import AudioChunk, decode_fwa1
from .errors import ConnectionClosed, FacewireError, ProtocolError
from .events import ServerError, StreamEnd
from .http import Client
from .viewer_frames import RestMesh, ViewerFrame, _FWF2_SECTIONS, decode_viewer_frame


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
