"""ADXL330 3-axis analog accelerometer read through a 12-bit ADC whose reference is the sensor supply.

The output is ratiometric: V = VS * (0.5 + 0.1/g * a) (300 mV/g at 3 V; registers.md section 2), so with
VREF = VS the codes do not depend on VS and mid-scale 2048 is 0 g.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Sequence

from drivers._analog import ADC_MID, check_plausible, validate_channels
from drivers.contract import Placement, Sensor, SupplyMonitor, Wiring, chip_driver
from drivers.units import STANDARD_GRAVITY

RATIO_PER_G = 0.1          # sensitivity as a fraction of VS per g [U, ADXL335 sibling]
RANGE_G = 3.0              # minimum full scale [D]
TURN_ON_S = 0.02           # about 160 * C_filt + 1 ms with 0.1 uF filter caps [U]


@chip_driver
class ADXL330(Sensor, SupplyMonitor):
    """ADXL330 on three ADC channels; optional supply monitor on `supply_channel` through a divider.

    `supply_divider` is V_adc / VS of that divider (0.5 for two equal resistors).
    """

    chip = "ADXL330"
    BUSES, SENSES, OPTIONS = ("adc",), ("accel",), ("supply_channel", "supply_divider", "turn_on_s")

    def __init__(self, adc: Any, channels: Sequence[int] = (0, 1, 2), *, supply_channel: int | None = None,
                 supply_divider: float = 0.5, turn_on_s: float = TURN_ON_S,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.channels = validate_channels(channels, self.chip)
        if supply_channel is not None and (type(supply_channel) is not int or not 0 <= supply_channel <= 7
                                           or supply_channel in self.channels):
            raise ValueError(f"{self.chip}: supply_channel must be a free ADC channel in 0..7, "
                             f"got {supply_channel!r}")
        if not 0 < supply_divider <= 1:
            raise ValueError(f"{self.chip}: supply_divider must be in (0, 1], got {supply_divider!r}")
        self.adc, self.supply_channel, self.supply_divider = adc, supply_channel, float(supply_divider)
        self.turn_on_s, self.sleep = turn_on_s, sleep

    def start(self) -> None:
        """Wait the turn-on time, then check every channel is off the rails (no identity on an analog part)."""
        self.sleep(self.turn_on_s)
        check_plausible(self.adc, self.channels, ("X", "Y", "Z"), self.chip)
        if self.supply_channel is not None:
            check_plausible(self.adc, (self.supply_channel,), ("supply monitor",), self.chip)

    def read_raw(self) -> tuple[int, int, int]:
        """Signed counts per axis: code - 2048 (0 g nominal at mid-scale)."""
        read, (cx, cy, cz) = self.adc.read, self.channels
        return read(cx) - ADC_MID, read(cy) - ADC_MID, read(cz) - ADC_MID

    def read_supply_v(self) -> float:
        """Sensor supply VS in volts from the divided supply channel."""
        if self.supply_channel is None:
            raise ValueError(f"{self.chip}: no supply_channel configured, so the supply cannot be read")
        return self.adc.read(self.supply_channel) * self.adc.vref / 4096 / self.supply_divider

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is m/s^2 per count (nominal, VREF = VS)."""
        return {
            "chip": self.chip, "interface": "analog", "channels": list(self.channels),
            "supply_channel": self.supply_channel,
            "range": RANGE_G, "range_unit": "g", "rate_hz": None,
            "scale": STANDARD_GRAVITY / (4096 * RATIO_PER_G), "scale_unit": "m/s^2 per LSB",
        }

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "ADXL330":
        return cls(wiring.adc_for(placement), placement.channels or (0, 1, 2), sleep=wiring.sleep,
                   **placement.options)
