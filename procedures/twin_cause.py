"""A cause the twin names: an effect of the vocabulary (effects.md), fitted from the recording, with the world's terms
that put it into a replica and the statistics it governs (`procedures.twin_extension` proposes them,
`procedures.twin_model` and `procedures.twin_hold` build some)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from rig.effects import unit_for


@dataclass
class Cause:
    effect: str                                    # the vocabulary's name (rig.effects), read from the world's term
    sensor: str
    magnitude: float                               # in the vocabulary's unit (`unit`)
    params: dict
    governs: tuple[str, ...]                       # statistic families it can move
    make: Callable[[int], list]                    # the world's effects for a replica's seed
    quiet: tuple[str, ...] = ()                    # sensors whose white noise it replaces
    brings_back: list[str] = field(default_factory=list)
    rate: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None   # rad/s it adds to the gyro at (t, f)
    base_unit: str | None = None                   # the sensor's unit where no scale gives the vocabulary's

    @property
    def unit(self) -> str:
        return unit_for(self.effect, self.sensor, self.base_unit)

