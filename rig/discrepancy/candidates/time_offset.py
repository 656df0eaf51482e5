"""The discrepancy analysis's candidate test of `time_offset`: latency between sensor samples and the reference."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import Candidate, candidate_test


@candidate_test("time_offset", needs=("moves",))
def time_offset(sensor: str) -> Candidate:
    return Candidate(lambda o, f: -o.rate_dot[:, :, None], ("t",), lambda c: float(c[0]), lambda c: {"tau_s": float(c[0])},
                     note="sensor reads omega(t - tau): residual = -tau d(omega)/dt",
                     against=lambda o: (np.degrees(o.rate_dot), "reference d(omega)/dt, deg/s^2"))
