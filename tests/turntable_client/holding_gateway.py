"""A Modbus TCP pass-through that acknowledges one COMMAND write itself and delivers it late (or never).

It stands for the drive that acknowledges a write but acts on it in a later cycle, or a gateway that
loses it after answering: the window in which IN_POSITION left over from the previous move is stale.
"""

from __future__ import annotations

import socket
import struct
import threading


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ConnectionError("closed")
        data += chunk
    return data


def _frame(sock: socket.socket) -> bytes:
    head = _recv_exact(sock, 7)                       # MBAP: tid, protocol, length, unit id
    length = struct.unpack(">H", head[4:6])[0]
    return head + _recv_exact(sock, length - 1)


class HoldingGateway:
    def __init__(self, upstream: tuple[str, int], clock) -> None:
        self.upstream, self.clock = upstream, clock
        self.hold_address: int | None = None
        self.deliver_after: int | None = None          # requests passed through before delivery; None: never
        self.held_at: float | None = None
        self.delivered_at: float | None = None
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        threading.Thread(target=self._accept, daemon=True).start()

    @property
    def url(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    def hold(self, address: int, deliver_after: int | None) -> None:
        self.hold_address, self.deliver_after = address, deliver_after

    def close(self) -> None:
        self._listener.close()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), daemon=True).start()

    def _serve(self, client: socket.socket) -> None:
        held, passed = None, 0
        with client, socket.create_connection(self.upstream) as up:
            while True:
                try:
                    request = _frame(client)
                except (ConnectionError, OSError):
                    return
                fc, address = request[7], struct.unpack(">H", request[8:10])[0]
                if held is None and self.hold_address is not None and fc == 6 and address == self.hold_address:
                    held, self.hold_address, self.held_at = request, None, self.clock.now()
                    client.sendall(request)                 # an FC06 response echoes the request
                    continue
                up.sendall(request)
                response = _frame(up)
                if held is not None and self.deliver_after is not None:
                    passed += 1
                    if passed >= self.deliver_after:      # while the client waits: deterministic timing
                        up.sendall(held)
                        _frame(up)
                        held, self.delivered_at = None, self.clock.now()
                client.sendall(response)
