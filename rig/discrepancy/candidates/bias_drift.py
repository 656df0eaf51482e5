"""The discrepancy analysis's candidate test of `bias_drift`: bias wander over the session."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, against_time, candidate_test, centred, per_axis
from rig.units import REPORT_UNITS


@candidate_test("bias_drift")
def bias_drift(sensor: str) -> Candidate:
    _, k = REPORT_UNITS[sensor]
    return Candidate(lambda o, f: per_axis(centred(o.t)), AXES, lambda c: float(np.abs(c).max() * 3600.0 / k),
                     lambda c: {"d_per_hour": (c * 3600.0 / k).tolist()}, against=against_time)
