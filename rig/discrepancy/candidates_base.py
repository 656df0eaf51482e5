"""What a candidate test is and its registry: one group of regressor columns per named effect of `effects.md` and
sensor. The tests themselves are the modules of `rig.discrepancy.candidates`, one per effect.

Each candidate test registers itself against its vocabulary name (`rig.effects`) with `@candidate_test(name,
needs=...)`: the vocabulary gives its sensors and unit, `needs` the covariates the session must have logged for it.
Each candidate turns the rows of one sensor into columns `Z` (n, 3, q) such that the residual of the
linear model gains `Z c` when the effect is present, `c` its coefficients (one label per column, the
axis the coefficient belongs to, for the Holm family of candidates x axes), and maps `c` back to the
vocabulary's magnitude and unit. Columns are first-order models of the laws of the simulator terms
(`fixtures/world/effects/`), written in the raw sensor axes where the effect acts after `inv(H)` (scale-like effects).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from rig.discrepancy.linear import TriadFit
from rig.discrepancy.observations import Observations
from rig.effects import effect as vocabulary_entry

AXES = ("x", "y", "z")


@dataclass
class Candidate:
    columns: Callable[[Observations, TriadFit], np.ndarray]            # (n, 3, q)
    labels: tuple[str, ...]
    magnitude: Callable[[np.ndarray], float]                          # c -> vocabulary magnitude
    params: Callable[[np.ndarray], dict] = field(default=lambda c: {})
    scan: Callable[[Observations], np.ndarray] | None = None          # values of a searched parameter
    scan_columns: Callable[[Observations, TriadFit, float], np.ndarray] | None = None
    note: str = ""
    # physics the data must agree with (e.g. the Earth's rate is 15.04 deg/h): (c, cov) -> reason or None
    implausible: Callable[[np.ndarray, np.ndarray], str | None] | None = None
    # the covariate its residual follows, for the plots: observations -> (values (n,) or (n, 3), label)
    against: Callable[[Observations], tuple[np.ndarray | None, str]] | None = None
    effect: str = ""              # set from the vocabulary when the library builds it
    sensor: str = ""
    unit: str = ""

    @property
    def key(self) -> str:
        return f"{self.effect}:{self.sensor}"


Build = Callable[[str], Candidate]
CANDIDATES: dict[str, tuple[Build, tuple[str, ...]]] = {}    # vocabulary name -> (build(sensor), needs)
COVARIATES = ("temp", "vsupply", "moves", "tumble_table")


def candidate_test(name: str, *, needs: tuple[str, ...] = ()) -> Callable[[Build], Build]:
    """Register the candidate test of effect `name`; `needs` are what the session must have for it: a varying
    temperature or supply, move windows, the tumble table of conventions.md (the geometry candidates)."""
    vocabulary_entry(name)
    unknown = set(needs) - set(COVARIATES)
    if unknown:
        raise ValueError(f"candidate {name!r} needs {sorted(unknown)}; known: {COVARIATES}")

    def register(build: Build) -> Build:
        if name in CANDIDATES:
            raise ValueError(f"effect {name!r} has two candidate tests")
        CANDIDATES[name] = (build, tuple(needs))
        return build
    return register


def per_axis(values: np.ndarray) -> np.ndarray:
    n = len(values)
    Z = np.zeros((n, 3, 3))
    for a in range(3):
        Z[:, a, a] = values
    return Z


def centred(x: np.ndarray) -> np.ndarray:
    return x - x.mean()


def against_temperature(o: Observations):
    return o.temp, "temperature, degC"


def against_time(o: Observations):
    return o.t, "time, s"
