"""The discrepancy analysis's tests of `accel_scale_nonlinearity`: second-order response."""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.regression import nested_f, resvar
from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test
from rig.discrepancy.recording_base import Test, recording_test


@candidate_test("accel_scale_nonlinearity")
def accel_scale_nonlinearity(sensor: str) -> Candidate:
    def cols(o, f):
        colnorm = np.linalg.norm(f.H, axis=0)
        s = f.predicted_z(o) * colnorm                      # physical value along each sensor axis
        return (f.H / colnorm)[None, :, :] * (s * s)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max()), lambda c: {"K2": c.tolist()},
                     note="measured = true + K2 true^2 per sensor axis",
                     against=lambda o: (o.f, "reference specific force, m/s^2"))


@recording_test("accel_scale_nonlinearity")
def in_a_recording(session, rec, table: dict, rng) -> list[Test]:
    """|a| - g of the poses that are not faces against the even term K2 u^2, beyond what B and H absorb.

    measured = u + K2 u^2 per axis moves |a| by sum_i K2_i u_i^3 / |u| (first order); a bias and a matrix move
    it along u_i / |u| and u_i u_j / |u|, which the calibration has already fitted away, so the test uses the
    part of the cubic signature those cannot make (Frisch-Waugh) and says how much of it the fit absorbs.
    """
    norm = session.gravity
    free = ~table["face"]
    if free.sum() < 16:
        return []
    f = table["f"][free]
    size = np.linalg.norm(f, axis=1)
    r = (size - norm)[:, None]
    unit = f / size[:, None]
    linear = np.column_stack([unit] + [unit[:, i] * f[:, j] for i in range(3) for j in range(i, 3)])
    cubic = f ** 3 / size[:, None]
    p, coef, cov = nested_f(np.hstack([linear, cubic]), linear, r)
    K2 = coef[-3:, 0]
    unc = float(np.sqrt(np.max(np.diag(cov)[-3:]) * resvar(np.hstack([linear, cubic]), r)[0]))
    kept = np.linalg.norm(cubic - linear @ np.linalg.lstsq(linear, cubic, rcond=None)[0]) / np.linalg.norm(cubic)
    return [Test("accel_scale_nonlinearity", "accel", p, float(np.abs(K2).max()), unc,
                 {"K2": K2.tolist(), "identifiable": float(kept)})]
