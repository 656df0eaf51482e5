"""How far the gravity a hand motion carries between two poses is trusted: across the motion's rotation (what it
says of its axis) and along it (what it says of its angle), apart.

A motion's carried gravity misses the next pose's by a small rotation. Part of it turns about the motion's own
axis: the angle came out wrong, as it does when the gyro's scale over that motion is not the one the rest of the
recording shows (a fast hand flip, a sample clock that runs unevenly). The rest turns across that axis: the axis
came out wrong, which is what a gyro's misalignment, or its frame against the accelerometer's, does. On imucal's
SI session the five flips miss by 0.60 deg RMS along their axes and 0.10 across under one weight for both (0.69 and
0.22 under imucal's calibration; bench_recordings' `carry_miss_split_deg`), while its three turns of known angle
are fitted to 0.01 deg. Weighed apart, the motions fix what turns by hand leave open (their axes) without their
angles pulling the scale the turns know."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

CARRY_SD = 0.005              # unit-vector components: gravity carried across a motion by hand (0.3 deg)
CARRY_SD_CHOICES = (0.005, 0.01, 0.02, 0.05, 0.1)   # across the axis, cross-validation chooses among (0.3 to 6 deg)
ANGLE_FACTORS = (1.0, 3.0, 10.0)    # along it, as many times as loose: with turns of known angle a motion's angle
                                    # repeats what they say of the scale, so it is trusted no more than its axis
UPRIGHT = 0.3                 # |axis x gravity| below this: a turn about the vertical, whose angle gravity hardly sees


@dataclass(frozen=True)
class CarryWeight:
    """Standard deviations (unit-vector components) of a motion's carried gravity: across its rotation axis and
    along it."""

    across_sd: float = CARRY_SD
    along_sd: float = CARRY_SD

    @property
    def isotropic(self) -> bool:
        return self.along_sd == self.across_sd

    @property
    def fits_motions(self) -> bool:
        return math.isfinite(self.across_sd)

    def extra(self) -> dict[str, float | str | None]:
        """The keys a gyro calibration's `extra` (and calibration.json) carries it under."""
        if not self.fits_motions:
            return {"carry_sd": None, "carry_angle_sd": None, "motions": TURNS_ONLY_KEY}
        return {"carry_sd": self.across_sd, "carry_angle_sd": self.along_sd}

    @classmethod
    def from_extra(cls, extra: dict) -> "CarryWeight | None":
        """The weight a calibration's `extra` names; None where its fit had no motions (a file written before the
        angle was weighed apart names one weight for both)."""
        if extra.get("motions") == TURNS_ONLY_KEY:
            return TURNS_ONLY
        if extra.get("carry_sd") is None:
            return None
        return cls(extra["carry_sd"], extra.get("carry_angle_sd", extra["carry_sd"]))


PRIOR = CarryWeight()
TURNS_ONLY_KEY = "not fitted: the turns alone predict them better"
TURNS_ONLY = CarryWeight(math.inf, math.inf)    # three turns fix H, and the motions add nothing they can show


def candidates() -> list[CarryWeight]:
    """Every weight cross-validation weighs, the prior first."""
    return [CarryWeight(sd, sd * f) for f in ANGLE_FACTORS for sd in CARRY_SD_CHOICES]


def angle_directions(q: np.ndarray, g_end: np.ndarray) -> np.ndarray:
    """Per motion (n,), the unit direction in which an error in its angle moves the carried gravity at its end:
    its rotation axis (of the quaternions q (n, 4), the same in both frames) across the end's gravity. Zero where
    the motion turns about the vertical (`UPRIGHT`): its whole miss is then weighed as across."""
    axis = q[:, 1:] / np.maximum(np.linalg.norm(q[:, 1:], axis=1, keepdims=True), 1e-300)
    d = np.cross(axis, g_end)
    size = np.linalg.norm(d, axis=1, keepdims=True)
    return np.where(size > UPRIGHT, d / np.maximum(size, 1e-300), 0.0)


def weighted_miss(miss: np.ndarray, along: np.ndarray | None, weight: CarryWeight) -> np.ndarray:
    """The carried gravity's miss (..., n, 3) in standard deviations: its part along each motion's angle
    direction (n, 3) over `along_sd`, the rest over `across_sd`."""
    if along is None or weight.isotropic:
        return miss / weight.across_sd
    a = np.einsum("...ki,ki->...k", miss, along)[..., None] * along
    return (miss - a) / weight.across_sd + a / weight.along_sd
