"""The discrepancy analysis's candidate test of `table_axis_misalignment`: table axes not orthogonal / encoder zero
offsets."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import Candidate, candidate_test
from rig.units import DEG


@candidate_test("table_axis_misalignment", needs=("tumble_table",))
def table_axis_misalignment(sensor: str) -> Candidate:
    """Tilt eps of the inner axis about fixture y between the gimbals, R = Rx(a) Ry(eps) Rz(b). Zero
    offsets and tilts about x or z equal a mounting rotation (absorbed by H) or a rotated reference
    (absorbed by v), so only this component is identifiable."""
    ey = np.array([0.0, 1.0, 0.0])

    def cols(o, f):
        if f.v is None:
            Z = np.zeros((o.n, 3, 1))
            Z[:, 2, 0] = o.outer_rate          # omega gains eps * adot e_z
            return Z
        a, b = np.radians(o.angles[:, 0]), np.radians(o.angles[:, 1])
        w = _rx_T(a, f.v)
        col = -_rz_T(b, np.cross(ey, w))
        return col[:, :, None]
    return Candidate(cols, ("eps",), lambda c: float(abs(c[0]) / DEG),
                     lambda c: {"tilt_y_deg": float(c[0] / DEG), "seen_by": sensor},
                     note="only the non-orthogonality of the gimbal axes (tilt about fixture y) is identifiable",
                     against=lambda o: (o.angles[:, 0], "outer angle, deg"))


def _rx_T(a, v):
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.full_like(a, v[0]), c * v[1] + s * v[2], -s * v[1] + c * v[2]], -1)


def _rz_T(b, w):
    c, s = np.cos(b), np.sin(b)
    return np.stack([c * w[:, 0] + s * w[:, 1], -s * w[:, 0] + c * w[:, 1], w[:, 2]], -1)
