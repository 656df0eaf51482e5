"""HMC1053 3-axis AMR bridge magnetometer behind an instrumentation amplifier and a 12-bit ADC.

With a set/reset driver, each reading is a SET sample minus a RESET sample: the pulse flips the bridge's
sensitivity sign but not its offset, so the difference holds twice the field and no bridge or amplifier
offset (registers.md section 6, HMC10xx family practice).
"""

from __future__ import annotations

import time
from typing import Any, Callable, Sequence

from drivers._analog import ADC_MID, check_plausible, validate_channels
from drivers.contract import Placement, Sensor, Wiring, chip_driver

SET, RESET = +1, -1
SENSITIVITY_V_PER_V_PER_GA = 1.0e-3   # 1.0 mV/V/gauss typ [D]
RANGE_GA = 6.0                        # [D]
UT_PER_GAUSS = 100.0
SETTLE_S = 1.0e-4                     # bridge + amplifier settling after a strap pulse [U]


@chip_driver
class HMC1053(Sensor):
    """HMC1053 on three ADC channels. `set_reset(+1)` fires a SET pulse, `set_reset(-1)` a RESET pulse."""

    chip = "HMC1053"
    BUSES, SENSES, OPTIONS = ("adc",), ("mag",), ("settle_s", "amp_gain", "bridge_v")

    def __init__(self, adc: Any, channels: Sequence[int] = (3, 4, 5),
                 set_reset: Callable[[int], None] | None = None, *, settle_s: float = SETTLE_S,
                 amp_gain: float = 100.0, bridge_v: float = 3.3,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.channels = validate_channels(channels, self.chip)
        if amp_gain <= 0 or bridge_v <= 0 or settle_s < 0:
            raise ValueError(f"{self.chip}: amp_gain and bridge_v must be > 0 and settle_s >= 0, got "
                             f"{amp_gain!r}, {bridge_v!r}, {settle_s!r}")
        self.adc, self.set_reset, self.settle_s, self.sleep = adc, set_reset, settle_s, sleep
        self.amp_gain, self.bridge_v = float(amp_gain), float(bridge_v)
        self.offset: tuple[float, float, float] | None = None

    def _read3(self) -> tuple[int, int, int]:
        read, (cx, cy, cz) = self.adc.read, self.channels
        return read(cx), read(cy), read(cz)

    def _pulse(self, polarity: int) -> None:
        self.set_reset(polarity)
        if self.settle_s:
            self.sleep(self.settle_s)

    def start(self) -> None:
        """Re-magnetise with a SET/RESET pair if a strap driver exists, then check the channels are off the rails."""
        if self.set_reset is not None:
            self._pulse(SET)
            check_plausible(self.adc, self.channels, ("X", "Y", "Z"), self.chip)
            self._pulse(RESET)
        check_plausible(self.adc, self.channels, ("X", "Y", "Z"), self.chip)

    def read_raw(self) -> tuple[int, int, int]:
        """Set/reset difference per axis (offset-free, 2x field), or code - 2048 without a strap driver.

        The offset estimate (set + reset)/2 - 2048 per axis is kept in `offset`.
        """
        if self.set_reset is None:
            x, y, z = self._read3()
            return x - ADC_MID, y - ADC_MID, z - ADC_MID
        self._pulse(SET)
        sx, sy, sz = self._read3()
        self._pulse(RESET)
        rx, ry, rz = self._read3()
        self.offset = ((sx + rx) / 2 - ADC_MID, (sy + ry) / 2 - ADC_MID, (sz + rz) / 2 - ADC_MID)
        return sx - rx, sy - ry, sz - rz

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is uT per count (nominal, from sensitivity and gains)."""
        vref = float(getattr(self.adc, "vref", self.bridge_v))
        counts_per_ga = SENSITIVITY_V_PER_V_PER_GA * self.bridge_v * self.amp_gain * 4096 / vref
        if self.set_reset is not None:
            counts_per_ga *= 2
        return {
            "chip": self.chip, "interface": "analog", "channels": list(self.channels),
            "set_reset": self.set_reset is not None,
            "range": RANGE_GA, "range_unit": "Ga", "rate_hz": None,
            "amp_gain": self.amp_gain, "bridge_v": self.bridge_v,
            "scale": UT_PER_GAUSS / counts_per_ga, "scale_unit": "uT per LSB",
        }

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "HMC1053":
        """The set/reset strap is driven from the placement's GPIO line when it has one (else no strap driver)."""
        set_reset = None
        if placement.gpio is not None:
            if wiring.gpio is None:
                raise ValueError(f"{placement.name} ({cls.chip}): set/reset on GPIO {placement.gpio[0]} line "
                                 f"{placement.gpio[1]}, but this rig has no GPIO access")
            set_reset = wiring.gpio(*placement.gpio)
        return cls(wiring.adc_for(placement), placement.channels or (3, 4, 5), set_reset=set_reset,
                   sleep=wiring.sleep, **placement.options)
