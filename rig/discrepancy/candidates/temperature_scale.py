"""The discrepancy analysis's candidate test of `temperature_scale`: sensitivity tempco."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, against_temperature, candidate_test, centred


@candidate_test("temperature_scale", needs=("temp",))
def temperature_scale(sensor: str) -> Candidate:
    def cols(o, f):
        z = f.predicted_z(o)
        return -f.H[None, :, :] * (centred(o.temp)[:, None] * z)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max() * 1e6), lambda c: {"s_ppm_per_degC": (c * 1e6).tolist()},
                     note="H(T) = H (1 + s (T - T0)) per sensor axis", against=against_temperature)
