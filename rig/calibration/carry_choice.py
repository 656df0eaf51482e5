"""How far to trust a recording's hand motions, chosen from the recording where turns of known angle say the same
things too: the weight whose fit best predicts each turn and each motion left out of it."""

from __future__ import annotations

import numpy as np

from rig.calibration.carry_weight import PRIOR, CarryWeight, candidates
from rig.calibration.recording_fits import carried_errors, gyro_rotation_fit, turn_angle
from rig.errors import CalibrationError

CV_GAIN = 0.5                 # another weight only where it halves the left-out errors (few pieces: a noisy choice)


def carry_weight_by_cross_validation(B: np.ndarray, turns: list, carries: list, H0: np.ndarray) -> CarryWeight:
    """Among `carry_weight.candidates()` (across the axis 0.3 to 6 deg, along it 1, 3 or 10 times that), the
    weight whose fit best predicts each turn and each motion left out of it (squared angle errors summed), kept
    only where it halves them against the prior. A careful hand keeps the prior; imucal's SI session's motions do
    not: their angles miss six times as far as their axes, and weighed apart its left-out turns fall from 1.03 to
    0.75 deg RMS and its left-out motions from 0.85 to 0.73 (bench_recordings)."""
    costs = {weight: _left_out_cost(B, turns, carries, H0, weight) for weight in candidates()}
    best = min(costs, key=costs.get)
    return best if costs[best] < CV_GAIN * costs[PRIOR] else PRIOR


def _left_out_cost(B: np.ndarray, turns: list, carries: list, H0: np.ndarray, weight: CarryWeight) -> float:
    """Squared angle errors of each turn and motion under the fit without it, taken one Gauss-Newton step from the
    fit on everything (`jackknife.one_step_deletions`: within a few per cent of a refit, at the cost of none)."""
    try:
        _, _, info = gyro_rotation_fit(B, turns, carries, H0=H0, carry=weight)
    except CalibrationError:
        return np.inf
    if info["rank"] < 9 or info["left_out_H"] is None:
        return np.inf
    left_out = info["left_out_H"]
    cost = sum((turn_angle(H, m, axis) - angle) ** 2 for H, (m, axis, angle, *_) in zip(left_out, turns))
    for H, (stream, g0, g1) in zip(left_out[len(turns):], carries):
        cost += float(carried_errors(H, B, [stream], g0[None], g1[None])[0]) ** 2
    return float(cost)
