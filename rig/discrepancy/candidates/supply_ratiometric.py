"""The discrepancy analysis's candidate test of `supply_ratiometric`: ratiometric output read against a fixed ADC
reference."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test, centred, per_axis


@candidate_test("supply_ratiometric", needs=("vsupply",))
def supply_ratiometric(sensor: str) -> Candidate:
    return Candidate(lambda o, f: per_axis(centred(o.vsupply)), AXES, lambda c: float(np.abs(c).max()),
                     lambda c: {"k": c.tolist()}, against=lambda o: (o.vsupply, "supply, V"))
