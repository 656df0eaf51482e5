"""The discrepancy analysis's tests of `gyro_g_sensitivity`: proof-mass response to specific force."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test
from rig.discrepancy.recording_base import pose_regressor
from rig.units import DEG, STANDARD_GRAVITY


@candidate_test("gyro_g_sensitivity")
def gyro_g_sensitivity(sensor: str) -> Candidate:
    def cols(o, f):
        Z = np.zeros((o.n, 3, 9))
        for a in range(3):
            Z[:, a, 3 * a:3 * a + 3] = o.f
        return Z
    return Candidate(cols, tuple(a for a in AXES for _ in range(3)),
                     lambda c: float(np.linalg.svd(c.reshape(3, 3), compute_uv=False)[0] * STANDARD_GRAVITY / DEG),
                     lambda c: {"Gs_deg_s_per_g": (c.reshape(3, 3) * STANDARD_GRAVITY / DEG).tolist()},
                     note="vertical Earth rate aliases into an isotropic Gs = -(Omega_v / g) I")


@pose_regressor("gyro_g_sensitivity", columns=lambda table: table["f"] / STANDARD_GRAVITY, rank=0)
def in_a_recordings_poses(c: np.ndarray, var: np.ndarray, resvar: np.ndarray) -> tuple[float, float, dict]:
    """The gyro's pose means (deg/s) against the calibrated specific force (g): G, deg/s per g."""
    return (float(np.linalg.svd(c.T, compute_uv=False)[0]), float(np.sqrt(np.max(var) * np.mean(resvar))),
            {"G_deg_s_per_g": c.T.tolist()})
