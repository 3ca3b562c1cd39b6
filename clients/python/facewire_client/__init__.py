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

The package is one module per concern, each re-exported here: :mod:`.protocol` (version,
server defaults), :mod:`.errors`, :mod:`.names` (units, FAPs, blendshapes),
:mod:`.producer_frames` (FWP2, FWP1, JSON), :mod:`.viewer_frames` (FWF2, FWF1, FWM1),
:mod:`.audio` (FWA1, PCM and WAV), :mod:`.events` (ends, server errors), :mod:`.http`
(:class:`Client`), :mod:`.producer`, :mod:`.viewer`, :mod:`.cli`, and :mod:`.aio`.
"""

from __future__ import annotations

from .protocol import (
    AUDIO_CHUNK_S, DEFAULT_MAX_FPS, DEFAULT_MAX_MESSAGE_BYTES, OPUS_RATE, PCM_RATES,
    PROTOCOL_VERSION,
)
from .errors import (
    AudioRefused, ConnectionClosed, FacewireError, FrameError, HttpError, ProtocolError,
    Refused,
)
from .names import (
    ANIMATION_UNITS, ANIMATION_UNIT_NAMES, ARKIT_BLENDSHAPES, FAP_NAMES, OCULUS_VISEMES,
    animation_unit_index, arkit_index, fap_number,
)
from .producer_frames import encode_fwp1, encode_fwp2, encode_json, read_jsonl
from .viewer_frames import (
    LipFolds, LipRoughness, PartDeltas, RestMesh, RigidMotion, ViewerFrame, decode_fwf1,
    decode_fwf2, decode_mesh, decode_viewer_frame,
)
from .audio import AudioChunk, decode_fwa1, encode_fwa1, opus_packet_samples
from .events import ServerError, StreamEnd
from .gltf_pack import avatar_file, pack_glb, read_glb
from .http import Client
from .producer import Ack, Derived, Producer
from .viewer import PartInfo, SectionInfo, Snapshot, Viewer, ViewerEvent
from .cli import main

__all__ = [
    "ANIMATION_UNITS",
    "ANIMATION_UNIT_NAMES",
    "ARKIT_BLENDSHAPES",
    "AUDIO_CHUNK_S",
    "Ack",
    "AudioChunk",
    "AudioRefused",
    "Client",
    "ConnectionClosed",
    "DEFAULT_MAX_FPS",
    "DEFAULT_MAX_MESSAGE_BYTES",
    "Derived",
    "FAP_NAMES",
    "FacewireError",
    "FrameError",
    "HttpError",
    "LipFolds",
    "LipRoughness",
    "OCULUS_VISEMES",
    "OPUS_RATE",
    "PCM_RATES",
    "PROTOCOL_VERSION",
    "PartDeltas",
    "PartInfo",
    "Producer",
    "ProtocolError",
    "Refused",
    "RestMesh",
    "RigidMotion",
    "SectionInfo",
    "ServerError",
    "Snapshot",
    "StreamEnd",
    "Viewer",
    "ViewerEvent",
    "ViewerFrame",
    "animation_unit_index",
    "arkit_index",
    "avatar_file",
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
    "main",
    "opus_packet_samples",
    "pack_glb",
    "read_glb",
    "read_jsonl",
]
