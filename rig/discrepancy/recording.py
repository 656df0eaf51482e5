"""What the linear model misses in a recording without a turntable, named in the effects.md vocabulary.

No reference orientation exists, so the tests use what the recording itself fixes: the calibrated specific force
of every static pose (the accelerometer tells how gravity lay), the pose's time, and the motions between poses
whose gravity the gyro must carry (imu_tk's criterion). Each effect a recording can show has its test in its own
module of `rig.discrepancy.candidates` (`rig.discrepancy.recording_base`): the effects seen in the gyro's pose
means (g-sensitivity, bias drift) are fitted together here by ordinary least squares on [1, blocks...], each
block tested by its nested F test against the model without it; the others (the gyro's delay against the
accelerometer, an even term in the accelerometer's poses) run their own test.
p-values are Holm-corrected over the tests run; a finding needs p < ALPHA after correction.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.g_sensitivity import pose_means
from rig.calibration.recordings.recording import RecordingCalibration
from rig.calibration.numerics.regression import nested_f, resvar
from rig.discrepancy.candidates import POSE_REGRESSORS, RECORDING_TESTS
from rig.discrepancy.recording_base import Test, subsample
from rig.discrepancy.stats import holm
from rig.effects import EFFECTS
from rig.session_data import SessionData
from rig.units import DEG

ALPHA = 0.01


def pose_table(session: SessionData, rec: RecordingCalibration) -> dict[str, np.ndarray]:
    """Per static pose: mid time, calibrated specific force (m/s^2) and gyro mean (rad/s)."""
    rows = [p.rows for p in rec.poses]
    out = pose_means(session, rec.sensors, rows)
    out["face"] = np.array([p.up is not None for p in rec.poses])
    return out


def gyro_pose_tests(table: dict) -> list[Test]:
    """Every effect registered in the gyro's pose means (`@pose_regressor`), each block against the model without it;
    with too few poses for every block, those of the highest rank are left out."""
    if "w" not in table:
        return []
    k = len(table["t"])
    ones = np.ones((k, 1))
    regressors = sorted(POSE_REGRESSORS.items(), key=lambda item: item[1].rank)
    blocks = {name: reg.columns(table) for name, reg in regressors}
    while blocks and k <= 1 + sum(b.shape[1] for b in blocks.values()) + 1:
        blocks.popitem()
    if not blocks:
        return []
    full = np.hstack([ones, *blocks.values()])
    w = table["w"] / DEG
    tests, start = [], 1
    for name, block in blocks.items():
        reduced = np.hstack([ones] + [b for n, b in blocks.items() if n != name])
        p, coef, cov = nested_f(full, reduced, w)
        idx = slice(start, start + block.shape[1])
        start += block.shape[1]
        magnitude, uncertainty, params = POSE_REGRESSORS[name].report(coef[idx], np.diag(cov)[idx], resvar(full, w))
        tests.append(Test(name, "gyro", p, magnitude, uncertainty, params))
    return tests


def recording_tests(session: SessionData, rec: RecordingCalibration, *,
                    rng: np.random.Generator | None = None) -> list[dict]:
    """Every test the recording supports, Holm-corrected; each as a finding candidate with `significant`.

    With `rng`, one subsample (the m-out-of-n bootstrap of Politis and Romano, m = 80 %, without replacement: a
    pose drawn twice would count as two independent ones in the tests): how stable the named set is under the
    recording's own scatter of poses and motions."""
    table = pose_table(session, rec)
    if rng is not None:
        pick = np.sort(rng.choice(len(table["t"]), subsample(len(table["t"])), replace=False))
        table = {k: v[pick] for k, v in table.items()}
    tests = gyro_pose_tests(table)
    for name in EFFECTS:
        if name in RECORDING_TESTS:
            tests += RECORDING_TESTS[name](session, rec, table, rng)
    adjusted = holm([t.p for t in tests])
    return [{"effect": t.effect, "sensor": t.sensor, "magnitude": t.magnitude, "unit": t.unit,
             "uncertainty": t.uncertainty, "p": t.p, "p_holm": float(h), "significant": bool(h < ALPHA),
             "params": t.params} for t, h in zip(tests, adjusted)]
