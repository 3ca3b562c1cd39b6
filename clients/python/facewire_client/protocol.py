"""The protocol's version and the server's defaults a client keeps to (``proto/PROTOCOL.md``)."""

from __future__ import annotations

from typing import Tuple

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
