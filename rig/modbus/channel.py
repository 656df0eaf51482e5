"""One Modbus link with bounded retries and exponential backoff through the injected clock.

pymodbus's own retries are off (see `url.make_client`): a blind re-send of a COMMAND whose response was
lost could start a second move, so only the caller knows whether a write may be repeated.
"""

from __future__ import annotations

import logging
import os
import socket
from collections.abc import Callable

import serial
from pymodbus.exceptions import ConnectionException, ModbusException

from rig.clock import Clock
from rig.modbus.errors import LinkErrors
from rig.modbus.url import LinkAddress, make_client

# pymodbus logs every failure it also reports by its return value or exception; the link reports each once, with
# its cause, so pymodbus's own lines ("Repeating....") are not passed on to the terminal.
logging.getLogger("pymodbus").addHandler(logging.NullHandler())
logging.getLogger("pymodbus").propagate = False

log = logging.getLogger(__name__)


class ModbusChannel:
    """FC03 / FC06 / FC16 to one device id; raises the `errors` classes' `modbus_exception` or
    `communication` (a lost reply to a non-idempotent write: `response_lost`). `device` names what is
    behind the link ("turntable", "chamber") in messages and log lines."""

    def __init__(self, address: LinkAddress, device_id: int, clock: Clock, timeout: float, retries: int,
                 backoff_s: float = 0.05, backoff_max_s: float = 1.0, device: str = "device",
                 errors: LinkErrors = LinkErrors()) -> None:
        if retries < 0:
            raise ValueError(f"retries must be >= 0, got {retries}")
        if not timeout > 0:
            raise ValueError(f"timeout must be positive, got {timeout}")
        self.address, self.device_id, self.clock = address, device_id, clock
        self.timeout, self.retries = timeout, retries
        self.backoff_s, self.backoff_max_s = backoff_s, backoff_max_s
        self.device, self.errors = device, errors
        self.client = None
        self.requests = 0
        self.failures = 0

    @property
    def is_open(self) -> bool:
        return self.client is not None

    def open(self) -> None:
        """Connect, retrying with backoff (a table may still be booting); a serial device that does not exist
        or cannot be opened is refused at once, since waiting will not make it appear."""
        if self.address.scheme == "rtu":
            _check_serial_device(self.address, self.device, self.errors)
        self.client = make_client(self.address, self.timeout)
        for attempt in range(self.retries + 1):
            if self.client.connect():
                return
            if attempt < self.retries:
                self.backoff(attempt, f"connect to {self.address}")
        self.client = None
        cause = connect_cause(self.address, self.timeout)
        raise self.errors.communication(f"cannot connect to the {self.device} at {self.address}: {cause} "
                                 f"({self.retries + 1} attempts)")

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None

    def read(self, address: int, count: int, register: str) -> list[int]:
        def call():
            return self.client.read_holding_registers(address, count=count, device_id=self.device_id)
        rr = self._transact(3, address, register, call, idempotent=True, count=count)
        return list(rr.registers)

    def write(self, address: int, words: list[int], register: str, idempotent: bool = True) -> None:
        """FC06 for one word, FC16 for several."""
        if len(words) == 1:
            fc, call = 6, lambda: self.client.write_register(address, words[0], device_id=self.device_id)
        else:
            fc, call = 16, lambda: self.client.write_registers(address, words, device_id=self.device_id)
        self._transact(fc, address, register, call, idempotent=idempotent)

    def _transact(self, fc: int, address: int, register: str, call: Callable, idempotent: bool,
                  count: int | None = None):
        if self.client is None:
            raise self.errors.communication(f"{self.device} link to {self.address} is not open")
        attempts = self.retries + 1 if idempotent else 1
        problem = ""
        for attempt in range(attempts):
            self.requests += 1
            try:
                rr = call()
            except (ModbusException, OSError) as exc:
                problem = f"{type(exc).__name__}: {exc}"
                self._recover(exc)
            else:
                if rr.isError():
                    raise self.errors.modbus_exception(rr.exception_code, fc, register, address)
                if count is None or len(rr.registers) == count:
                    return rr
                problem = f"response has {len(rr.registers)} registers, asked for {count}"
            self.failures += 1
            if attempt + 1 < attempts:
                self.backoff(attempt, f"FC{fc:02d} {register} @0x{address:04X} ({problem})")
        where = f"FC{fc:02d} {register} @0x{address:04X} on {self.address}"
        if not idempotent:
            raise self.errors.response_lost(f"{where}: no valid response ({problem}); not re-sent")
        raise self.errors.communication(f"{where}: no valid response after {attempts} attempts ({problem})")

    def _recover(self, exc: Exception) -> None:
        """Drop a TCP connection after a failure so a late reply cannot be taken for the next one's
        (RTU clients flush stale input before each send instead)."""
        if not self.address.is_serial_client or isinstance(exc, ConnectionException):
            self.client.close()

    def backoff(self, attempt: int, what: str) -> None:
        delay = min(self.backoff_s * 2 ** attempt, self.backoff_max_s)
        log.warning("%s: %s failed, retry %d/%d in %.3f s", self.device, what, attempt + 1, self.retries, delay)
        self.clock.sleep(delay)


def _check_serial_device(address: LinkAddress, what: str, errors: LinkErrors) -> None:
    device = address.device
    if not os.path.exists(device):
        raise errors.communication(f"{what} at {address}: no such device {device} (is the adapter plugged in? "
                                 "`ls /dev/tty*` lists the serial ports)")
    if not os.access(device, os.R_OK | os.W_OK):
        raise errors.communication(f"{what} at {address}: permission denied on {device} (add the user to the "
                                 "group that owns it, e.g. dialout)")


def connect_cause(address: LinkAddress, timeout: float) -> str:
    """Why a connection fails, in the operating system's words (pymodbus's connect() only says that it did)."""
    if address.scheme == "rtu":
        try:
            serial.Serial(address.device, baudrate=address.baud).close()
            return f"{address.device} opened on a second try, then the Modbus client could not use it"
        except (serial.SerialException, OSError, ValueError) as exc:
            return str(exc)
    try:
        with socket.create_connection((address.host, address.port), timeout=timeout):
            return "the connection opened on a second try, then the Modbus client could not use it"
    except socket.timeout:
        return f"no answer within {timeout:g} s (host down, or a firewall drops the connection)"
    except OSError as exc:
        return exc.strerror or str(exc)
