"""The errors a facewire client raises: one base class, and what each failure names."""

from __future__ import annotations

from typing import Optional, Sequence


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
