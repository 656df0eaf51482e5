"""A cause the twin names: an effect of the vocabulary (effects.md), fitted from the recording, with the world's terms
that put it into a replica and the statistics it governs (`procedures.twin.extension` proposes them,
`procedures.twin.model` and `procedures.twin.hold` build some)."""

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
    quiet: tuple[str, ...] = ()                    # sensors whose white noise its own terms replace
    brings_back: list[str] = field(default_factory=list)
    pushes_out: list[str] = field(default_factory=list)   # statistics inside before it, outside with it
    rate: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None   # rad/s it adds to the gyro at (t, f)
    base_unit: str | None = None                   # the sensor's unit where no scale gives the vocabulary's
    # sensor -> the terms of its white noise at the level this cause needs beneath it (the quiet poses' where a hand
    # disturbed the others), shared with any other cause that names the same: given once in a replica
    floor: dict[str, Callable[[int], list]] = field(default_factory=dict)
    model: bool = False                            # found by a recording test (`procedures.twin.model`)

    @property
    def unit(self) -> str:
        return unit_for(self.effect, self.sensor, self.base_unit)


def terms_of(causes: list[Cause], seed: int) -> list:
    """The world's terms of `causes` together in the replica of `seed`: each cause's own, and each sensor's white
    noise floor once (from the first cause that gives it, where no cause's own terms replace it already)."""
    out = [term for cause in causes for term in cause.make(seed)]
    given = {sensor for cause in causes for sensor in cause.quiet}
    for cause in causes:
        for sensor, floor in cause.floor.items():
            if sensor not in given:
                out += floor(seed)
                given.add(sensor)
    return out


def quiet_of(causes: list[Cause]) -> tuple[str, ...]:
    """The sensors whose plain white noise the terms of `causes` replace."""
    return tuple(sorted({s for c in causes for s in c.quiet} | {s for c in causes for s in c.floor}))

