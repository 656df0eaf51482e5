"""The tests of a recording without a turntable (`rig.discrepancy.recording`) and their registry: each effect that a
recording can show registers its test in its own module of `rig.discrepancy.candidates`, next to its candidate test
on turntable sessions, so the recording analysis names no effect itself.

Two kinds: an effect seen in a sensor's pose means (`@pose_regressor`) gives a block of regressors, and the blocks
of all such effects are fitted together, each tested by its nested F test against the model without it
(`rig.calibration.numerics.regression`); any other test (`@recording_test`) reads the session, its calibration and the
pose table and returns its `Test`s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rig.effects import effect as vocabulary_entry
from rig.effects import unit_for


@dataclass
class Test:
    effect: str
    sensor: str
    p: float
    magnitude: float
    uncertainty: float
    params: dict

    @property
    def unit(self) -> str:
        return unit_for(self.effect, self.sensor)


Report = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[float, float, dict]]


@dataclass(frozen=True)
class PoseRegressor:
    """An effect in the gyro's pose means: `columns(table)` (k, q) of the pose table, and `report(c, var, resvar)`
    -> (magnitude, uncertainty, params) from its coefficients c (q, 3), their (X^T X)^-1 diagonal and the full
    model's residual variance per axis. With too few poses for every block, those of the highest `rank` go first."""

    columns: Callable[[dict], np.ndarray]
    report: Report
    rank: int


RecordingTest = Callable[..., list[Test]]       # (session, rec, table, rng) -> tests
POSE_REGRESSORS: dict[str, PoseRegressor] = {}  # vocabulary name -> its block of the gyro's pose-mean regression
RECORDING_TESTS: dict[str, RecordingTest] = {}  # vocabulary name -> its own test


def pose_regressor(name: str, *, columns: Callable[[dict], np.ndarray], rank: int) -> Callable[[Report], Report]:
    """Register `name`'s block of the gyro's pose-mean regression: its `columns` of the pose table; the decorated
    function is its `report`."""
    vocabulary_entry(name)

    def register(report: Report) -> Report:
        if name in POSE_REGRESSORS or name in RECORDING_TESTS:
            raise ValueError(f"effect {name!r} has two recording tests")
        POSE_REGRESSORS[name] = PoseRegressor(columns, report, rank)
        return report
    return register


def recording_test(name: str):
    """Register `name`'s own test of a recording: `test(session, rec, table, rng) -> list[Test]`."""
    vocabulary_entry(name)

    def register(test: RecordingTest) -> RecordingTest:
        if name in POSE_REGRESSORS or name in RECORDING_TESTS:
            raise ValueError(f"effect {name!r} has two recording tests")
        RECORDING_TESTS[name] = test
        return test
    return register


def subsample(n: int) -> int:
    """The m of the m-out-of-n bootstrap (m = 80 %)."""
    return max(int(0.8 * n), 1)
