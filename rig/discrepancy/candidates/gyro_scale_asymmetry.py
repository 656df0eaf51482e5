"""The discrepancy analysis's candidate test of `gyro_scale_asymmetry`: different scale for positive and negative
rates."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test


@candidate_test("gyro_scale_asymmetry", needs=("moves",))
def gyro_scale_asymmetry(sensor: str) -> Candidate:
    """Columns H[:, i] mean(max(zhat_i, 0)) with zhat = inv(H) omega_ref per sample: the positive part
    of the noise-free raw rate (the measured one would add E[max(noise, 0)] = 0.4 sigma at rest, a
    fake offset between still and moving rows)."""
    def cols(o, f):
        zhat = o.rate_samples @ np.linalg.inv(f.H).T
        ypos = np.nanmean(np.maximum(zhat, 0.0), axis=1)
        return f.H[None, :, :] * ypos[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max() * 100.0), lambda c: {"delta_percent": (c * 100.0).tolist()},
                     note="extra relative scale for positive rates per sensor axis",
                     against=lambda o: (np.degrees(o.rate), "reference rate, deg/s"))
