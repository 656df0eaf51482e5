"""The discrepancy analysis's candidate test of `temperature_bias`: bias tempco."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, against_temperature, candidate_test, centred, per_axis
from rig.units import REPORT_UNITS


@candidate_test("temperature_bias", needs=("temp",))
def temperature_bias(sensor: str) -> Candidate:
    _, k = REPORT_UNITS[sensor]
    return Candidate(lambda o, f: per_axis(centred(o.temp)), AXES, lambda c: float(np.abs(c).max() / k),
                     lambda c: {"k": (c / k).tolist()}, note="bias += k (T - T0), fixture axes", against=against_temperature)
