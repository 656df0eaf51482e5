"""Whether a session's reference quaternions turn the way conventions.md says (fixture -> world).

Another tool may write the table's orientation the other way round (world -> fixture, the conjugate). Gravity
then lies in the fixture frame where the table never put it: with a horizontal outer axis R g instead of R^T g
stays in one plane, and the session was refused as "the reference directions are coplanar", which sent the user
to the schedule. The accelerometer's hold means tell which way is right without any calibration: they are an
affine image of the fixture-frame gravity direction, `y = A d + b`, under the right convention and not under the
wrong one.
"""

from __future__ import annotations

import numpy as np

from rig.errors import CalibrationError
from rig.session_data import HoldStats, SessionData

CONJUGATE_GAIN = 10.0       # the conjugate must fit the hold means this many times better (RMS) to be named
MIN_HOLDS = 6               # 4 unknowns per axis of the affine fit, and some to spare


def affine_misfit(means: np.ndarray, d: np.ndarray) -> float:
    """RMS residual of the hold means against the best affine image of the directions d (k, 3)."""
    X = np.hstack([d, np.ones((len(d), 1))])
    coef, *_ = np.linalg.lstsq(X, means, rcond=None)
    return float(np.sqrt(np.mean((means - X @ coef) ** 2)))


def refuse_conjugated_reference(session: SessionData, accel: HoldStats) -> None:
    """Raise CalibrationError naming the quaternion columns where their conjugates explain the accelerometer's
    holds CONJUGATE_GAIN times better than they do."""
    ok = ~np.isnan(accel.mean).any(axis=1)
    if ok.sum() < MIN_HOLDS:
        return
    means, R = accel.mean[ok], accel.R[ok]
    up = np.array([0.0, 0.0, 1.0])
    as_given = affine_misfit(means, np.einsum("kji,j->ki", R, up))        # R^T up: fixture -> world, as specified
    conjugated = affine_misfit(means, np.einsum("kij,j->ki", R, up))      # R up: what world -> fixture would mean
    if conjugated * CONJUGATE_GAIN < as_given:
        raise CalibrationError(
            f"{session.source}: the reference quaternions (qw, qx, qy, qz) look like world -> fixture: their "
            f"conjugates fit the accelerometer's {int(ok.sum())} holds {as_given / max(conjugated, 1e-300):.3g} "
            "times better; session-csv.md and conventions.md want fixture -> world (v_world = q v_fixture q*): "
            "negate qx, qy and qz")
