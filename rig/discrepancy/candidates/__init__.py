"""The candidate library: the discrepancy analysis's tests of each effect of the vocabulary, one module per effect:
its candidate test on turntable sessions (`@candidate_test`, `rig.discrepancy.candidates_base`) and, where a
recording without a turntable can show it, its recording test (`@pose_regressor` or `@recording_test`,
`rig.discrepancy.recording_base`). Every module of this package is imported here (`rig.effects.discover`), so a
new effect's file is found without being listed anywhere; `library` reads the complete registry.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rig.discrepancy.candidates_base import AXES, CANDIDATES, COVARIATES, Candidate, candidate_test
from rig.discrepancy.observations import Observations
from rig.discrepancy.recording_base import POSE_REGRESSORS, RECORDING_TESTS
from rig.effects import EFFECTS, discover

__all__ = ["AXES", "CANDIDATES", "COVARIATES", "POSE_REGRESSORS", "RECORDING_TESTS", "Candidate", "candidate_test",
           "library"]

discover(__name__, __path__)


def library(sensor: str, obs: Observations, *, tumble_table: bool = True) -> list[Candidate]:
    """The candidate of every effect of the vocabulary that acts on this sensor and whose covariates the session
    has, in the vocabulary's order. The table-geometry candidates are written for the tumble table of
    conventions.md (outer axis world x, inner axis fixture z); on another table they are left out
    (`tumble_table=False`)."""
    have = {"temp": obs.temp is not None and np.ptp(obs.temp) > 0,
            "vsupply": obs.vsupply is not None and np.ptp(obs.vsupply) > 0,
            "moves": bool(obs.is_move.any()), "tumble_table": tumble_table}
    out: list[Candidate] = []
    for name, spec in EFFECTS.items():
        if name not in CANDIDATES or sensor not in spec.tested_on:
            continue
        build, needs = CANDIDATES[name]
        if all(have[n] for n in needs):
            out.append(replace(build(sensor), effect=name, sensor=sensor, unit=spec.unit_for(sensor)))
    return out
