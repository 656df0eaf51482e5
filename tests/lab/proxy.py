"""A counting TCP relay on loopback, in front of the lab's PostgreSQL server, one per rig: every connection a
rig opens is an attempt, counted with its time, whatever then happens to it. When the server behind is down
the relay closes the rig's connection at once, as a refused connection would end it, and still counts it, so
a retry storm is measured as the server would have suffered it. `cut()` takes the server away from behind it
(every open connection dropped, every new one closed at once) until `restore()`."""

from __future__ import annotations

import asyncio
import threading
import time


class CountingProxy:
    def __init__(self, target_port: int, host: str = "127.0.0.1") -> None:
        self.target = (host, target_port)
        self.attempts: list[float] = []          # time.monotonic() of every accepted connection
        self.refusing = False
        self._open: set[asyncio.StreamWriter] = set()
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, name="counting-proxy", daemon=True)
        self._thread.start()
        self._ready.wait(10)

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        self._server = self._loop.run_until_complete(asyncio.start_server(self._relay, "127.0.0.1", 0))
        self.port = self._server.sockets[0].getsockname()[1]
        self._ready.set()
        self._loop.run_forever()

    async def _relay(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.attempts.append(time.monotonic())
        if self.refusing:
            writer.close()
            return
        try:
            up_reader, up_writer = await asyncio.open_connection(*self.target)
        except OSError:
            writer.close()
            return
        self._open |= {writer, up_writer}
        try:
            await asyncio.gather(_pipe(reader, up_writer), _pipe(up_reader, writer))
        finally:
            self._open -= {writer, up_writer}

    def cut(self) -> None:
        """The server gone: open connections dropped, new ones closed as they come."""
        def drop() -> None:
            self.refusing = True
            for w in list(self._open):
                w.transport.abort()

        self._loop.call_soon_threadsafe(drop)

    def restore(self) -> None:
        self.refusing = False

    def url(self, db: str, user: str) -> str:
        return f"postgresql://{user}@127.0.0.1:{self.port}/{db}"

    def between(self, start: float, end: float) -> list[float]:
        return [t for t in self.attempts if start <= t <= end]

    def close(self) -> None:
        def stop() -> None:
            self._server.close()
            self._loop.stop()

        self._loop.call_soon_threadsafe(stop)
        self._thread.join(10)


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    try:
        while data := await reader.read(65536):
            writer.write(data)
            await writer.drain()
    except (ConnectionError, OSError):
        pass
    finally:
        writer.close()
