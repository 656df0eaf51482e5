"""Link URLs: which transport, where, and with what serial settings.

`tcp://HOST:PORT` is Modbus TCP; `rtu:///dev/ttyUSB0?baud=115200&parity=N&stopbits=1&bytesize=8` is RTU
on a serial port through pyserial; `rtu+socket://HOST:PORT` is RTU framing over TCP (serial-to-Ethernet
gateways; the fake devices serve it too, so the tests exercise the RTU framing).
"""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import parse_qs, urlsplit

from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from rig.modbus.rtu import LineSpeedSerialClient

SCHEMES = ("tcp", "rtu", "rtu+socket")
SERIAL_DEFAULTS = {"baud": 115200, "parity": "N", "stopbits": 1, "bytesize": 8}


@dataclass(frozen=True)
class LinkAddress:
    scheme: str
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = 115200
    parity: str = "N"
    stopbits: int = 1
    bytesize: int = 8

    @property
    def is_serial_client(self) -> bool:
        """A serial device through pyserial: stale bytes are flushed before each send, no reconnect needed
        (a gateway's TCP stream is dropped and reopened after a failure, like Modbus TCP)."""
        return self.scheme == "rtu"

    def __str__(self) -> str:
        if self.scheme == "rtu":
            return (f"rtu://{self.device}?baud={self.baud}&parity={self.parity}"
                    f"&stopbits={self.stopbits}&bytesize={self.bytesize}")
        return f"{self.scheme}://{self.host}:{self.port}"


def parse_url(url: str, device: str = "link") -> LinkAddress:
    """Parse a link URL; a bad one raises ValueError naming the offending part (and `device`, what it
    leads to)."""
    if not isinstance(url, str) or "://" not in url:
        raise ValueError(f"{device} URL {url!r}: missing scheme; use one of {', '.join(s + '://' for s in SCHEMES)}")
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in SCHEMES:
        raise ValueError(f"{device} URL {url!r}: scheme {parts.scheme!r} is not one of {', '.join(SCHEMES)}")
    if scheme == "rtu":
        return _serial(url, parts, device)
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise ValueError(f"{device} URL {url!r}: unexpected path or query {parts.path + parts.query!r} "
                         f"after HOST:PORT")
    if not parts.hostname:
        raise ValueError(f"{device} URL {url!r}: missing host")
    try:
        port = parts.port
    except ValueError:
        raise ValueError(f"{device} URL {url!r}: port is not an integer in 0..65535") from None
    if port is None:
        if scheme != "tcp":
            raise ValueError(f"{device} URL {url!r}: missing port")
        port = 502
    return LinkAddress(scheme, host=parts.hostname, port=port)


def _serial(url: str, parts, device: str) -> LinkAddress:
    if parts.netloc:
        raise ValueError(f"{device} URL {url!r}: host part {parts.netloc!r} given; "
                         f"a serial device is rtu:///dev/ttyX (three slashes)")
    if not parts.path:
        raise ValueError(f"{device} URL {url!r}: missing serial device path")
    query = parse_qs(parts.query, keep_blank_values=True, strict_parsing=False)
    settings = dict(SERIAL_DEFAULTS)
    for key, values in query.items():
        if key not in settings:
            raise ValueError(f"{device} URL {url!r}: unknown query parameter {key!r}; "
                             f"allowed: {', '.join(SERIAL_DEFAULTS)}")
        settings[key] = _serial_setting(url, key, values[-1], device)
    return LinkAddress("rtu", device=parts.path, **settings)


def _serial_setting(url: str, key: str, text: str, device: str) -> int | str:
    if key == "parity":
        if text.upper() not in ("N", "E", "O"):
            raise ValueError(f"{device} URL {url!r}: parity={text!r} must be N, E or O")
        return text.upper()
    allowed = {"stopbits": (1, 2), "bytesize": (7, 8)}.get(key)
    try:
        value = int(text)
    except ValueError:
        raise ValueError(f"{device} URL {url!r}: {key}={text!r} is not an integer") from None
    if (allowed and value not in allowed) or value <= 0:
        raise ValueError(f"{device} URL {url!r}: {key}={value} not allowed"
                         + (f" (one of {allowed})" if allowed else ""))
    return value


def make_client(address: LinkAddress, timeout: float) -> ModbusTcpClient | ModbusSerialClient:
    """A pymodbus sync client with its own retries OFF: the link retries, so a COMMAND is never re-sent blindly.

    RTU through a gateway is RTU framing on a TCP stream, so pymodbus's TCP transport carries it (pyserial's
    `socket://` would hand the framer one byte per millisecond); a serial device gets the line-speed client.
    """
    if address.scheme == "tcp":
        return ModbusTcpClient(address.host, port=address.port, timeout=timeout, retries=0)
    if address.scheme == "rtu+socket":
        return ModbusTcpClient(address.host, port=address.port, framer=FramerType.RTU, timeout=timeout, retries=0)
    return LineSpeedSerialClient(address.device, framer=FramerType.RTU, baudrate=address.baud,
                                 parity=address.parity, stopbits=address.stopbits, bytesize=address.bytesize,
                                 timeout=timeout, retries=0)
