"""The producer and the viewer for asyncio programs.

:class:`AsyncProducer` and :class:`AsyncViewer` are :class:`facewire_client.Producer` and
:class:`facewire_client.Viewer` behind coroutines: each call runs the blocking one in a
worker thread (:func:`asyncio.to_thread`), one call at a time per connection, so the event
loop never waits on the socket and two coroutines never share it at once. Errors are the
same exceptions. ::

    async with await AsyncProducer.connect("http://127.0.0.1:8480", "scan") as producer:
        await producer.play(frames, audio="voice.wav")

    async with await AsyncViewer.connect("http://127.0.0.1:8480", "scan", audio="pcm") as viewer:
        async for event in viewer:
            ...
"""

from __future__ import annotations

import asyncio
import os
from typing import Any, AsyncIterator, Iterable, List, Mapping, Optional, Sequence, Union

from . import Ack, Producer, StreamEnd, Viewer, ViewerEvent

__all__ = ["AsyncProducer", "AsyncViewer"]


class _Serial:
    """Runs blocking calls of one connection in a thread, one after the other."""

    def __init__(self) -> None:
        self._lock = asyncio.Lock()

    async def run(self, function: Any, *args: Any, **kwargs: Any) -> Any:
        async with self._lock:
            return await asyncio.to_thread(function, *args, **kwargs)


class AsyncProducer:
    """A :class:`facewire_client.Producer` for asyncio: the same methods, awaited."""

    def __init__(self, producer: Producer) -> None:
        self.producer = producer
        self._serial = _Serial()

    @classmethod
    async def connect(cls, url: str, head: str, stream: str = "main", **options: Any) -> "AsyncProducer":
        """Connects as ``Producer(url, head, stream, **options)`` does."""
        return cls(await asyncio.to_thread(Producer, url, head, stream, **options))

    async def __aenter__(self) -> "AsyncProducer":
        return self

    async def __aexit__(self, kind: Any, value: Any, traceback: Any) -> None:
        await self._serial.run(self.producer.__exit__, kind, value, traceback)

    async def send(self, frame: Mapping[str, Any], **options: Any) -> Ack:
        return await self._serial.run(self.producer.send, frame, **options)

    async def play(self, frames: Iterable[Mapping[str, Any]], **options: Any) -> List[Ack]:
        return await self._serial.run(self.producer.play, list(frames), **options)

    async def send_audio(self, t_s: float, samples: Union[Sequence[int], bytes, bytearray],
                         sample_rate: int = 16000, **options: Any) -> float:
        return await self._serial.run(self.producer.send_audio, t_s, samples, sample_rate, **options)

    async def send_opus(self, t_s: float, packet: bytes, **options: Any) -> float:
        return await self._serial.run(self.producer.send_opus, t_s, packet, **options)

    async def send_wav(self, path: Union[str, "os.PathLike[str]"], t_s: float = 0.0, **options: Any) -> float:
        return await self._serial.run(self.producer.send_wav, path, t_s, **options)

    async def check_audio(self, timeout: float = 0.0) -> None:
        await self._serial.run(self.producer.check_audio, timeout)

    async def end(self) -> StreamEnd:
        return await self._serial.run(self.producer.end)

    async def close(self) -> None:
        await self._serial.run(self.producer.close)


class AsyncViewer:
    """A :class:`facewire_client.Viewer` for asyncio: ``async for`` over its events."""

    def __init__(self, viewer: Viewer) -> None:
        self.viewer = viewer
        self._serial = _Serial()

    @classmethod
    async def connect(cls, url: str, head: str, stream: str = "main", **options: Any) -> "AsyncViewer":
        """Connects (snapshot and rest mesh read) as ``Viewer(url, head, stream, **options)``."""
        return cls(await asyncio.to_thread(Viewer, url, head, stream, **options))

    async def __aenter__(self) -> "AsyncViewer":
        return self

    async def __aexit__(self, kind: Any, value: Any, traceback: Any) -> None:
        await self.close()

    async def recv(self, timeout: Optional[float] = None) -> Optional[ViewerEvent]:
        """The next event, or None when ``timeout`` passes first."""
        return await self._serial.run(self.viewer.recv, timeout)

    def __aiter__(self) -> AsyncIterator[ViewerEvent]:
        return self._events()

    async def _events(self) -> AsyncIterator[ViewerEvent]:
        events = self.viewer.events()
        done = object()
        while True:
            event = await self._serial.run(next, events, done)
            if event is done:
                return
            yield event

    async def close(self) -> None:
        await self._serial.run(self.viewer.close)
