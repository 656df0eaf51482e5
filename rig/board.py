"""Sensor boards: which chips sit on which bus, composed into the triads a procedure reads.

Two profiles from the issue: `bsn` (ADXL330 through an MCP3208, ITG-3200, HMC5843) and `wearable`
(ADXL312, three ADXRS453, HMC1053 through the MCP3208). The buses are given already open, real or fake:
this module never knows which.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

from drivers import ADXL312, ADXL330, ADXRS453, HMC1053, HMC5843, ITG3200, MCP3208, GyroTriad
from drivers import adxrs453 as _adxrs453, mcp3208 as _mcp3208

# default placement per board; [chips] in the rig TOML overrides keys
PLACEMENT = {
    "bsn": {"adc_cs": 0, "accel_channels": (0, 1, 2), "supply_channel": 7, "gyro_address": 0x68,
            "mag_address": 0x1E, "rate_hz": 100.0, "mag_rate_hz": 50.0},
    "wearable": {"adc_cs": 0, "accel_address": 0x53, "gyro_cs": (1, 2, 3), "mag_channels": (3, 4, 5),
                 "rate_hz": 100.0, "accel_range_g": 1.5},
}


@dataclass
class SensorBoard:
    kind: str
    triads: dict[str, Any]
    parts: list[Any]
    temperature: Callable[[], float] | None = None
    supply: Callable[[], float] | None = None
    placement: dict = field(default_factory=dict)

    def start(self) -> None:
        for part in self.parts:
            part.start()

    def read_temperature(self) -> float | None:
        return None if self.temperature is None else self.temperature()

    def read_supply(self) -> float | None:
        return None if self.supply is None else self.supply()

    def settings(self) -> dict:
        out = {"board": self.kind, "placement": {k: (list(v) if isinstance(v, tuple) else v)
                                                   for k, v in self.placement.items()}}
        for name, triad in self.triads.items():
            s = getattr(triad, "settings", None)
            out[name] = s() if s else {"chip": type(triad).__name__}
        return out


def build_board(kind: str, *, i2c: Any, spi: Callable[[int, int, int], Any], set_reset: Callable[[int], None] | None = None,
                sleep: Callable[[float], None] = time.sleep, overrides: dict | None = None) -> SensorBoard:
    """The board `kind` on an open I2C bus and an SPI opener `spi(chip_select, mode, max_speed_hz)`."""
    if kind not in PLACEMENT:
        raise ValueError(f"unknown board {kind!r}; allowed: {sorted(PLACEMENT)}")
    p = {**PLACEMENT[kind], **(overrides or {})}
    if kind == "bsn":
        adc = MCP3208(spi(p["adc_cs"], _mcp3208.SPI_MODE, _mcp3208.SPI_MAX_HZ), vref=3.3)
        accel = ADXL330(adc, tuple(p["accel_channels"]), supply_channel=p["supply_channel"], sleep=sleep)
        gyro = ITG3200(i2c, p["gyro_address"], rate_hz=p["rate_hz"], sleep=sleep)
        mag = HMC5843(i2c, p["mag_address"], rate_hz=p["mag_rate_hz"], sleep=sleep)
        return SensorBoard(kind, {"accel": accel, "gyro": gyro, "mag": mag}, [adc, accel, gyro, mag],
                           gyro.read_temperature, accel.read_supply_v, p)
    adc = MCP3208(spi(p["adc_cs"], _mcp3208.SPI_MODE, _mcp3208.SPI_MAX_HZ), vref=3.3)
    accel = ADXL312(i2c, p["accel_address"], range_g=p["accel_range_g"], rate_hz=p["rate_hz"], sleep=sleep)
    gyro = GyroTriad([ADXRS453(spi(cs, _adxrs453.SPI_MODE, _adxrs453.SPI_MAX_HZ), sleep=sleep)
                      for cs in p["gyro_cs"]])
    mag = HMC1053(adc, tuple(p["mag_channels"]), set_reset=set_reset, sleep=sleep)
    return SensorBoard(kind, {"accel": accel, "gyro": gyro, "mag": mag}, [adc, accel, gyro, mag],
                       gyro.gyros[0].read_temperature, None, p)
