"""Audio chunks: ``FWA1`` (PROTOCOL.md, "Audio (FWA1)"; ``proto/src/audio_chunk.rs``), Opus packet
durations, and the PCM and WAV helpers producers and batches send voices with."""

from __future__ import annotations

import io
import math
import struct
import sys
import wave
from array import array
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple, Union

from .errors import FrameError, ProtocolError
from .names import _U64_MAX
from .protocol import AUDIO_CHUNK_S, OPUS_RATE, PCM_RATES
from .viewer_frames import _Reader, _next_section


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
