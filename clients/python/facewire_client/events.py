"""What a stream's socket says besides frames and audio: its end (:class:`StreamEnd`) and the
server's refusals and errors (:class:`ServerError`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional


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
