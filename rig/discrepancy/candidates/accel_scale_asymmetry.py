"""The discrepancy analysis's candidate test of `accel_scale_asymmetry`: different scale for positive and negative
specific force (an asymmetric rest position of the proof mass)."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test


@candidate_test("accel_scale_asymmetry")
def accel_scale_asymmetry(sensor: str) -> Candidate:
    """Columns H[:, i] max(zhat_i, 0), zhat = inv(H) f_ref the noise-free raw value of each hold: the positive
    side of each sensor axis reads (1 + delta_i) times its scale. Of |zhat_i| the linear part goes to H and the
    rest (even in the input) stays, which the norm of gravity over many poses separates from a constant bias."""
    def cols(o, f):
        return f.H[None, :, :] * np.maximum(f.predicted_z(o), 0.0)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max() * 100.0), lambda c: {"delta_percent": (c * 100.0).tolist()},
                     note="extra relative scale for positive values per sensor axis",
                     against=lambda o: (o.f, "reference specific force, m/s^2"))
