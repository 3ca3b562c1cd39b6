"""WebSocket plumbing shared by producers and viewers: their URLs, and websocket-client
connections with close codes, timeouts and HTTP refusals turned into this package's errors."""

from __future__ import annotations

import json
import struct
import urllib.error
import urllib.parse
import urllib.request
from typing import Any, Dict, Mapping, Optional, Tuple, Union

from .errors import ConnectionClosed, FacewireError, HttpError, ProtocolError, Refused


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
