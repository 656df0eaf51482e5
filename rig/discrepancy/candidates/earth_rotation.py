"""The discrepancy analysis's candidate test of `earth_rotation`: the Earth's rotation, a real input the reference
leaves out."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test
from rig.units import DEG

EARTH_RATE_DEG_H = 15.041   # sidereal rate


def _not_the_earth(c: np.ndarray, cov: np.ndarray) -> str | None:
    """The Earth's rate has a known size: a fitted |Omega| far from it is another effect with the same
    columns (an isotropic g-sensitivity looks like a vertical rate), not the Earth."""
    mag = np.linalg.norm(c) / DEG * 3600.0
    sd = np.sqrt(max(float(np.trace(cov)), 0.0)) / DEG * 3600.0
    if abs(mag - EARTH_RATE_DEG_H) > max(4.0 * sd, 0.3 * EARTH_RATE_DEG_H):
        return f"|Omega| = {mag:.3g} deg/h is not the Earth's {EARTH_RATE_DEG_H} deg/h (sd {sd:.2g})"
    return None


@candidate_test("earth_rotation")
def earth_rotation(sensor: str) -> Candidate:
    return Candidate(lambda o, f: np.transpose(o.R, (0, 2, 1)), AXES, lambda c: float(np.linalg.norm(c) / DEG * 3600.0),
                     lambda c: {"Omega_world_deg_h": (c / DEG * 3600.0).tolist()},
                     note="rate += R^T Omega; its vertical part is indistinguishable from isotropic g-sensitivity",
                     implausible=_not_the_earth)
