"""The discrepancy analysis's candidate test of `table_magnetic_disturbance`: field of a motor carried by the outer
gimbal."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import Candidate, candidate_test


@candidate_test("table_magnetic_disturbance", needs=("tumble_table",))
def table_magnetic_disturbance(sensor: str) -> Candidate:
    """Field of iron carried by the outer gimbal, `Rz(-inner) d`. Of d (outer-gimbal frame) only d_y is
    identifiable: d_x lies along the outer axis, so it is a world-fixed field along x that the fitted
    geomagnetic reference absorbs; d_z is fixed in the fixture frame, which the hard-iron bias absorbs."""
    def cols(o, f):
        b = np.radians(o.angles[:, 1])
        return np.stack([np.sin(b), np.cos(b), np.zeros_like(b)], -1)[:, :, None]
    return Candidate(cols, ("y",), lambda c: float(abs(c[0])), lambda c: {"d_uT": [None, float(c[0]), None]},
                     note="field += Rz(-inner) d; only d_y is identifiable (d_x is absorbed by the fitted "
                          "geomagnetic reference, d_z by the hard-iron bias), so the magnitude is |d_y|",
                     against=lambda o: (o.angles[:, 1], "inner angle, deg"))
