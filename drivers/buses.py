"""Open real buses. spidev is an optional extra (`pip install rig[spi]`), so it is imported only when needed."""

from __future__ import annotations

from typing import Any

import smbus2


def open_i2c(bus_number: int) -> smbus2.SMBus:
    """/dev/i2c-<bus_number> as an smbus2.SMBus."""
    return smbus2.SMBus(bus_number)


def open_spi(bus: int, device: int, mode: int, max_speed_hz: int) -> Any:
    """/dev/spidev<bus>.<device> as a spidev.SpiDev; mode and speed are set after open (spidev refuses before)."""
    try:
        import spidev
    except ImportError as exc:
        raise ImportError("drivers.open_spi needs the optional 'spidev' package: "
                          "pip install 'rig[spi]' (or pip install spidev)") from exc
    if mode not in (0, 1, 2, 3):
        raise ValueError(f"SPI mode must be 0..3, got {mode!r}")
    spi = spidev.SpiDev()
    spi.open(bus, device)
    spi.mode = mode
    spi.max_speed_hz = max_speed_hz
    return spi
