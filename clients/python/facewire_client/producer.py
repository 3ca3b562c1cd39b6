"""A producer: parameter frames and the voice to ``/v1/heads/{id}/streams/{stream}/produce``."""

from __future__ import annotations

import os
import time
import urllib.error
import urllib.parse
import urllib.request
from array import array
from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union, cast

from ._socket import _Socket, _base_urls, _refused, _segment, _server_message
from .audio import AudioChunk, _open_wav, _pcm_chunks, _pcm_samples, _read_wav, encode_fwa1
from .errors import AudioRefused, ConnectionClosed, FacewireError, FrameError, ProtocolError, Refused
from .events import StreamEnd
from .producer_frames import _frame_seq, _number, encode_fwp1, encode_fwp2, encode_json
from .protocol import AUDIO_CHUNK_S, DEFAULT_MAX_FPS, DEFAULT_MAX_MESSAGE_BYTES, OPUS_RATE


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
