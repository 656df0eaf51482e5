"""Modbus RTU on a serial line at the speed of the line.

pymodbus's sync serial client waits for a reply by sleeping a receive interval (4 character times, at least
1 ms) until the count of waiting bytes stops changing, so every reply costs a millisecond or two beyond its
bytes, and through pyserial's `socket://` (which only says whether *any* byte waits) one millisecond per
byte. Here a read blocks in `select` until bytes arrive and returns all that wait, so a reply is handed to
the RTU framer as its bytes come off the line.
"""

from __future__ import annotations

import fcntl
import select
import struct
import termios
import time

from pymodbus.client import ModbusSerialClient
from pymodbus.exceptions import ConnectionException


class LineSpeedSerialClient(ModbusSerialClient):
    """`ModbusSerialClient` whose receive is driven by the line's bytes rather than by a polling interval."""

    def recv(self, size: int | None) -> bytes:
        if not self.socket:
            raise ConnectionException(str(self))
        fd = self.socket.fileno()
        deadline = time.monotonic() + (self.comm_params.timeout_connect or 0.0)
        try:
            while True:
                waiting = _bytes_waiting(fd)
                if waiting:
                    return self.socket.read(waiting if size is None else min(size, waiting))
                left = deadline - time.monotonic()
                if left <= 0:
                    return b""
                select.select([fd], [], [], left)
        except (BlockingIOError, InterruptedError):
            raise
        except OSError:
            self.close()
            raise ConnectionException(str(self)) from None


def _bytes_waiting(fd: int) -> int:
    return struct.unpack("I", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]
