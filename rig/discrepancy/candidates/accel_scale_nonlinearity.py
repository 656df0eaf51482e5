"""The discrepancy analysis's candidate test of `accel_scale_nonlinearity`: second-order response."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test


@candidate_test("accel_scale_nonlinearity")
def accel_scale_nonlinearity(sensor: str) -> Candidate:
    def cols(o, f):
        colnorm = np.linalg.norm(f.H, axis=0)
        s = f.predicted_z(o) * colnorm                      # physical value along each sensor axis
        return (f.H / colnorm)[None, :, :] * (s * s)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max()), lambda c: {"K2": c.tolist()},
                     note="measured = true + K2 true^2 per sensor axis",
                     against=lambda o: (o.f, "reference specific force, m/s^2"))
