"""How far to trust a recording's hand motions, chosen from the recording where turns of known angle say the same
things too: the weight whose fit best predicts each turn and each motion left out of it; and, where the turns
alone fix H, whether the motions belong in the fit at all."""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.carry_weight import PRIOR, TURNS_ONLY, CarryWeight, candidates
from rig.calibration.recordings.recording_fits import carried_errors, gyro_rotation_fit, turn_angle
from rig.errors import CalibrationError

CV_GAIN = 0.5                 # another weight only where it halves the left-out errors (few pieces: a noisy choice)


def carry_weight_by_cross_validation(B: np.ndarray, turns: list, carries: list, H0: np.ndarray) -> CarryWeight:
    """Among `carry_weight.candidates()` (across the axis 0.3 to 6 deg, along it 1, 3 or 10 times that), the
    weight whose fit best predicts each turn and each motion left out of it (squared angle errors summed), kept
    only where it halves them against the prior. A careful hand keeps the prior; imucal's SI session's motions do
    not: their angles miss six times as far as their axes, and weighed apart its left-out turns fall from 1.03 to
    0.75 deg RMS and its left-out motions from 0.85 to 0.73 (bench_recordings).

    Where the turns alone fix H's nine entries, a left-out turn asks how well the motions stand in for it, which
    the fit on every turn never needs. There the motions stay only where that weight's fit predicts each motion
    left out of it better than the turns alone predict it (`TURNS_ONLY` otherwise): on imucal's SI session the
    turns alone predict its five motions to 0.726 deg RMS, the motions' own fit to 0.734."""
    costs = {weight: _left_out_costs(B, turns, carries, H0, weight) for weight in candidates()}
    total = {weight: sum(cost) for weight, cost in costs.items()}
    best = min(total, key=total.get)
    chosen = best if total[best] < CV_GAIN * total[PRIOR] else PRIOR
    alone = _turns_alone_cost(B, turns, carries, H0)
    return TURNS_ONLY if alone is not None and alone <= costs[chosen][1] else chosen


def _left_out_costs(B: np.ndarray, turns: list, carries: list, H0: np.ndarray,
                    weight: CarryWeight) -> tuple[float, float]:
    """Squared angle errors of each turn, and of each motion, under the fit without it, taken one Gauss-Newton step
    from the fit on everything (`jackknife.one_step_deletions`: within a few per cent of a refit, at the cost of
    none)."""
    try:
        _, _, info = gyro_rotation_fit(B, turns, carries, H0=H0, carry=weight)
    except CalibrationError:
        return np.inf, np.inf
    if info["rank"] < 9 or info["left_out_H"] is None:
        return np.inf, np.inf
    left_out = info["left_out_H"]
    turn_cost = sum((turn_angle(H, m, axis) - angle) ** 2 for H, (m, axis, angle, *_) in zip(left_out, turns))
    motion_cost = sum(float(carried_errors(H, B, [stream], g0[None], g1[None])[0]) ** 2
                      for H, (stream, g0, g1) in zip(left_out[len(turns):], carries))
    return float(turn_cost), float(motion_cost)


def _turns_alone_cost(B: np.ndarray, turns: list, carries: list, H0: np.ndarray) -> float | None:
    """Squared angle errors of every motion under the fit on the turns alone (none of them in it: each is left
    out); None where the turns alone do not fix H."""
    try:
        H, _, info = gyro_rotation_fit(B, turns, [], H0=H0)
    except CalibrationError:
        return None
    if info["rank"] < 9:
        return None
    streams, g0, g1 = zip(*carries)
    return float(np.sum(carried_errors(H, B, list(streams), np.array(g0), np.array(g1)) ** 2))
