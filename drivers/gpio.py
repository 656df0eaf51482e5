"""A set/reset strap driver on one GPIO line, through the kernel's GPIO character device (libgpiod v2).

The usual HMC10xx set/reset circuit (a MOSFET H-bridge behind a coupling capacitor, Honeywell's application
note circuit [U]) turns an edge of one logic line into a strap pulse: a rising edge sends SET current, a
falling edge RESET current. So `line(+1)` drives the line high and `line(-1)` low; the HMC1053 driver always
alternates them, so every call is an edge. `gpiod` is the optional extra `rig[gpio]` (PyPI `gpiod` >= 2), and a
test passes a module with the same API subset (`fixtures.gpio.FakeGpiod`).
"""

from __future__ import annotations

import errno
from typing import Any

from drivers.errors import BusError, DeviceAbsent

CONSUMER = "rig set/reset"


def _gpiod() -> Any:
    try:
        import gpiod
    except ImportError as exc:
        raise ImportError("the HMC1053 set/reset line needs the optional 'gpiod' package (libgpiod v2 binding): "
                          "pip install 'rig[gpio]'") from exc
    return gpiod


class SetResetLine:
    """One requested output line; call with +1 (SET, rising edge) or -1 (RESET, falling edge)."""

    def __init__(self, request: Any, offset: int, values: Any, where: str) -> None:
        self.request, self.offset, self.where = request, offset, where
        self._high, self._low = values.ACTIVE, values.INACTIVE

    def __call__(self, polarity: int) -> None:
        if polarity not in (1, -1):
            raise ValueError(f"{self.where}: set/reset polarity must be +1 (SET) or -1 (RESET), got {polarity!r}")
        try:
            self.request.set_value(self.offset, self._high if polarity > 0 else self._low)
        except OSError as exc:
            raise BusError(f"{self.where}: setting the line failed: {exc}") from exc

    def close(self) -> None:
        """Release the line (the kernel returns it to its default state)."""
        self.request.release()


def open_set_reset_line(chip_path: str, offset: int, *, gpiod: Any = None) -> SetResetLine:
    """Request `offset` on `chip_path` (e.g. /dev/gpiochip0) as an output, starting low (the RESET state)."""
    gpiod = gpiod or _gpiod()
    where = f"set/reset GPIO {chip_path} line {offset}"
    values = gpiod.line.Value
    settings = gpiod.LineSettings(direction=gpiod.line.Direction.OUTPUT, output_value=values.INACTIVE)
    try:
        request = gpiod.request_lines(chip_path, consumer=CONSUMER, config={offset: settings})
    except FileNotFoundError as exc:
        raise DeviceAbsent(f"{where}: no such GPIO chip ({exc.strerror}); check the path "
                           f"(`gpiodetect` lists the chips)") from exc
    except PermissionError as exc:
        raise BusError(f"{where}: permission denied; add the user to the 'gpio' group") from exc
    except OSError as exc:
        why = "the line is in use by another consumer" if exc.errno == errno.EBUSY else str(exc)
        raise BusError(f"{where}: cannot request the line: {why}") from exc
    except ValueError as exc:
        raise BusError(f"{where}: {exc}") from exc
    return SetResetLine(request, offset, values, where)
