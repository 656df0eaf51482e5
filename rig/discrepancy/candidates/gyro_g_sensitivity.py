"""The discrepancy analysis's candidate test of `gyro_g_sensitivity`: proof-mass response to specific force."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test
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
