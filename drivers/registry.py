"""The registry of chips: one entry per part a board may place, keyed by the part's `chip` name.

A board (`rig.boards`) names chips from here; the real and the simulated rig build them through their
`attach` class method; the simulated rig finds each chip's emulator in `fixtures.chips.registry`. Adding a
chip = its driver module plus one line here.
"""

from __future__ import annotations

from drivers.adxl312 import ADXL312
from drivers.adxl330 import ADXL330
from drivers.adxrs453 import ADXRS453, GyroTriad
from drivers.contract import Part
from drivers.hmc1053 import HMC1053
from drivers.hmc5843 import HMC5843
from drivers.itg3200 import ITG3200
from drivers.lsm6dso import LSM6DSO
from drivers.mcp3208 import MCP3208

CHIPS: dict[str, type[Part]] = {cls.chip: cls for cls in (
    MCP3208, ADXL312, ADXL330, ADXRS453, GyroTriad, ITG3200, HMC5843, HMC1053, LSM6DSO,
)}


def chip_class(name: str) -> type[Part]:
    """The registered part class for `name`; ValueError listing every registered chip otherwise."""
    try:
        return CHIPS[name]
    except KeyError:
        raise ValueError(f"unknown chip {name!r}; registered: {sorted(CHIPS)}") from None
