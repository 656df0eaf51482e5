"""The registry of sensor boards: which chip sits on which bus, address, chip select, ADC channel or GPIO line.

Declared as data and read by the configuration (board names, the keys `[chips.<part>]` may override), the real
assembly and the simulated rig (which builds the matching emulators from `fixtures.chips.registry`). Parts are
listed in build order: an ADC before the analog sensors read through it. Adding a board = one entry here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

from drivers.contract import Placement

SET_RESET_GPIO = ("/dev/gpiochip0", 17)   # HMC1053 strap driver line on the wearable board [U: board wiring]


@dataclass(frozen=True)
class BoardSpec:
    name: str
    parts: tuple[Placement, ...]
    triads: Mapping[str, str]                 # "accel" / "gyro" / "mag" -> the part that measures it
    temperature: str | None = None            # part whose die temperature is the session's temperature column
    supply: str | None = None                 # part that reads the sensor supply
    description: str = ""
    names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "names", tuple(p.name for p in self.parts))
        for triad, part in self.triads.items():
            if part not in self.names:
                raise ValueError(f"board {self.name}: triad {triad} names part {part!r}, not on the board")

    def part(self, name: str) -> Placement:
        for p in self.parts:
            if p.name == name:
                return p
        raise ValueError(f"board {self.name} has no part {name!r}; parts: {list(self.names)}")


BOARDS: dict[str, BoardSpec] = {b.name: b for b in (
    BoardSpec("bsn", (
        Placement("adc", "MCP3208", "spi", cs=0, options={"vref": 3.3}),
        Placement("accel", "ADXL330", "adc", adc="adc", channels=(0, 1, 2), options={"supply_channel": 7}),
        Placement("gyro", "ITG-3200", "i2c", address=0x68, options={"rate_hz": 100.0}),
        Placement("mag", "HMC5843", "i2c", address=0x1E, options={"rate_hz": 50.0}),
    ), {"accel": "accel", "gyro": "gyro", "mag": "mag"}, temperature="gyro", supply="accel",
        description="ADXL330 on MCP3208 channels 0-2 (supply on channel 7), ITG-3200 at 0x68, HMC5843 at 0x1E"),
    BoardSpec("wearable", (
        Placement("adc", "MCP3208", "spi", cs=0, options={"vref": 3.3}),
        Placement("accel", "ADXL312", "i2c", address=0x53, options={"range_g": 1.5, "rate_hz": 100.0}),
        Placement("gyro", "ADXRS453 triad", "spi", cs=(1, 2, 3)),
        Placement("mag", "HMC1053", "adc", adc="adc", channels=(3, 4, 5), gpio=SET_RESET_GPIO),
    ), {"accel": "accel", "gyro": "gyro", "mag": "mag"}, temperature="gyro",
        description="ADXL312 at 0x53, ADXRS453 on chip selects 1-3 (x, y, z), HMC1053 on MCP3208 channels "
                    "3-5 with set/reset on GPIO line 17"),
    BoardSpec("lsm6dso", (
        Placement("imu", "LSM6DSO", "i2c", address=0x6A, options={"odr_hz": 104, "accel_range_g": 4,
                                                                  "gyro_range_dps": 2000}),
        Placement("mag", "HMC5843", "i2c", address=0x1E, options={"rate_hz": 50.0}),
    ), {"accel": "imu", "gyro": "imu", "mag": "mag"}, temperature="imu",
        description="LSM6DSO (accelerometer + gyroscope, FIFO) at 0x6A, HMC5843 at 0x1E"),
)}
