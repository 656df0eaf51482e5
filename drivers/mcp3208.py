"""MCP3208 12-bit 8-channel SPI ADC (mode 0).

Uses the common three-byte full-duplex frame (datasheet fig. 6-1): TX `[0x04 | SGL<<1 | D2, D1 D0 << 6, 0]`,
RX byte 1 = `? ? ? NULL B11..B8`, byte 2 = `B7..B0`. The null bit is always low on a real converter, so a high
null bit means nobody drives MISO or the frame is misaligned.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from drivers._regs import spi_label
from drivers.contract import Part, Placement, Wiring, chip_driver
from drivers.errors import DeviceAbsent, ProtocolError, wrap_os_error

START = 0x04
SINGLE_ENDED = 0x02
NULL_BIT = 0x10
FULL_SCALE = 4096
CHANNELS = range(8)
DIFF_PAIRS = {0: "CH0+/CH1-", 1: "CH1+/CH0-", 2: "CH2+/CH3-", 3: "CH3+/CH2-",
              4: "CH4+/CH5-", 5: "CH5+/CH4-", 6: "CH6+/CH7-", 7: "CH7+/CH6-"}

SPI_MODE = 0
SPI_MAX_HZ = 1_000_000  # about 20 clocks per sample, 50 ksps at 2.7 V [U]


def command_bytes(code: int, single_ended: bool) -> tuple[int, int]:
    """First two TX bytes for channel/pair `code` (D2:D0)."""
    return START | (SINGLE_ENDED if single_ended else 0) | (code >> 2), (code & 0x03) << 6


_SINGLE = {ch: command_bytes(ch, True) for ch in CHANNELS}
_DIFF = {pair: command_bytes(pair, False) for pair in DIFF_PAIRS}


@chip_driver
class MCP3208(Part):
    """MCP3208 on a spidev-like object; `vref` (volts) converts codes to volts."""

    chip = "MCP3208"
    BUSES, OPTIONS = ("spi",), ("vref",)

    def __init__(self, spi: Any, *, vref: float = 3.3, cs: Any = None,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if not vref > 0:
            raise ValueError(f"{self.chip}: vref must be > 0 V, got {vref!r}")
        self.spi, self.vref, self.sleep = spi, float(vref), sleep
        self.location = f"{self.chip} on SPI {spi_label(spi, cs)}"

    def start(self) -> None:
        """No identity register: one conversion of CH0 checks that a converter drives MISO (null bit low)."""
        self.read(0)

    def _convert(self, b0: int, b1: int, what: str) -> int:
        try:
            rx = self.spi.xfer2([b0, b1, 0x00])
        except OSError as exc:
            raise wrap_os_error(exc, f"{self.location}, {what}", f"frame {b0:02X} {b1:02X} 00") from exc
        if rx[1] & NULL_BIT:
            raise self._bad_frame(rx, b0, b1, what)
        return ((rx[1] & 0x0F) << 8) | rx[2]

    def _bad_frame(self, rx: list, b0: int, b1: int, what: str) -> Exception:
        frame = f"TX {b0:02X} {b1:02X} 00, RX {rx[0]:02X} {rx[1]:02X} {rx[2]:02X}"
        if rx[1] == 0xFF and rx[2] == 0xFF:
            return DeviceAbsent(f"{self.location}, {what}: {frame}: MISO stuck high (ADC absent or unpowered?)")
        return ProtocolError(f"{self.location}, {what}: {frame}: null bit (RX byte 1 bit 4) is high")

    def read(self, channel: int) -> int:
        """12-bit code (0..4095) of single-ended `channel` 0..7."""
        cmd = _SINGLE.get(channel) if type(channel) is int else None
        if cmd is None:
            raise ValueError(f"{self.chip}: unsupported channel {channel!r}; allowed: 0..7")
        b0, b1 = cmd
        try:
            rx = self.spi.xfer2([b0, b1, 0x00])
        except OSError as exc:
            raise wrap_os_error(exc, f"{self.location}, channel {channel}", "conversion") from exc
        if rx[1] & NULL_BIT:
            raise self._bad_frame(rx, b0, b1, f"channel {channel}")
        return ((rx[1] & 0x0F) << 8) | rx[2]

    def read_differential(self, pair: int) -> int:
        """12-bit code of pseudo-differential `pair` 0..7 (D2:D0: 0 = CH0+/CH1-, 1 = CH1+/CH0-, ...)."""
        cmd = _DIFF.get(pair) if type(pair) is int else None
        if cmd is None:
            raise ValueError(f"{self.chip}: unsupported differential pair {pair!r}; allowed: "
                             + ", ".join(f"{k} ({v})" for k, v in DIFF_PAIRS.items()))
        return self._convert(cmd[0], cmd[1], f"pair {pair} {DIFF_PAIRS[pair]}")

    def read_voltage(self, channel: int) -> float:
        """Single-ended input in volts: code * vref / 4096."""
        return self.read(channel) * self.vref / FULL_SCALE

    def settings(self) -> dict:
        return {"chip": self.chip, "interface": "spi", "location": self.location, "vref_v": self.vref,
                "bits": 12, "scale": self.vref / FULL_SCALE, "scale_unit": "V per LSB"}

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "MCP3208":
        spi = wiring.bus_for(placement, SPI_MODE, SPI_MAX_HZ)
        return cls(spi, cs=placement.cs, sleep=wiring.sleep, **placement.options)
