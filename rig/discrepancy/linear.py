"""The baseline model `u = H (y - B)` of one triad, its residual against the reference, and the
Jacobian the nested tests project candidate effects off.

Residual per row: `r = H (y - B) - ref`, with `ref = R^T v` (accelerometer, magnetometer: `v` the
gravity or field vector in the world, its direction fitted, `|v|` fixed) or the table's body rate
(gyroscope). `r` is linear in (B, H) for fixed `v`, so a Gauss-Newton step of the extended model is
one weighted least-squares solve; F tests on that linearisation are the nested tests of
effects-research.md section 2.1 (Frisch-Waugh-Lovell).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.turntable.observability import tangent_basis
from rig.discrepancy.observations import Observations
from rig.errors import CalibrationError


@dataclass
class TriadFit:
    B: np.ndarray                # (3,) counts
    H: np.ndarray                # (3, 3) unit per count
    v: np.ndarray | None         # (3,) world reference (None for the gyro)
    norm: float | None = None

    def reference(self, obs: Observations) -> np.ndarray:
        if self.v is None:
            return obs.rate
        return np.einsum("kji,j->ki", obs.R, self.v)

    def calibrated(self, obs: Observations) -> np.ndarray:
        return (obs.y - self.B) @ self.H.T

    def residual(self, obs: Observations) -> np.ndarray:
        return self.calibrated(obs) - self.reference(obs)

    def sigma(self, obs: Observations) -> np.ndarray:
        """Standard error of each residual channel in calibrated units."""
        return np.sqrt((obs.sigma ** 2) @ (self.H ** 2).T)

    def predicted_z(self, obs: Observations) -> np.ndarray:
        """Noise-free raw deviation the model predicts, inv(H) ref."""
        return np.linalg.solve(self.H, self.reference(obs).T).T

    def jacobian(self, obs: Observations) -> np.ndarray:
        """d r / d(B, vec H row-major, v tangent) as (n, 3, p), with the H columns at the predicted
        (noise-free) raw values: a candidate that is a function of the reference then projects off
        exactly when the base can absorb it, instead of fitting the noise that measured values carry."""
        n = obs.n
        z = self.predicted_z(obs)
        p = 12 if self.v is None else 14
        J = np.zeros((n, 3, p))
        J[:, :, 0:3] = -self.H
        for a in range(3):
            J[:, a, 3 + 3 * a:6 + 3 * a] = z
        if self.v is not None:
            E = tangent_basis(self.v) * self.norm
            J[:, :, 12:14] = -np.einsum("kji,jd->kid", obs.R, E)
        return J

    def updated(self, delta: np.ndarray) -> "TriadFit":
        B = self.B + delta[0:3]
        H = self.H + delta[3:12].reshape(3, 3)
        v = self.v
        if v is not None:
            w = v + tangent_basis(v) * self.norm @ delta[12:14]
            v = self.norm * w / np.linalg.norm(w)
        return replace(self, B=B, H=H, v=v)


def flat(a: np.ndarray) -> np.ndarray:
    """(n, 3, q) -> (3n, q) or (n, 3) -> (3n,), rows ordered (row, channel)."""
    return a.reshape(a.shape[0] * 3, *a.shape[2:])


def solve_step(fit: TriadFit, obs: Observations, Z: np.ndarray | None = None, w: np.ndarray | None = None):
    """One weighted Gauss-Newton step of base (+ columns Z, (n, 3, q)): r = -J delta + Z c.
    Returns (delta, c)."""
    w = flat(1.0 / fit.sigma(obs)) if w is None else w
    J = flat(fit.jacobian(obs))
    X = J if Z is None else np.hstack([J, flat(Z)])
    beta, *_ = np.linalg.lstsq(X * w[:, None], flat(fit.residual(obs)) * w, rcond=None)
    p = J.shape[1]
    return -beta[:p], beta[p:]


def polish(fit: TriadFit, obs: Observations, iterations: int = 3) -> TriadFit:
    for _ in range(iterations):
        delta, _ = solve_step(fit, obs)
        fit = fit.updated(delta)
    return fit


def fit_baseline(obs: Observations, kind: str, norm: float | None) -> TriadFit:
    """The linear model, started from the project's joint calibration (accelerometer, magnetometer) or
    from hold means and window rates (gyroscope: B as Zhang 2015 eq. 41, H by least squares of the
    reference rates on the raw rates, which is exact for this linear model and needs no integration),
    then polished to the weighted least-squares optimum of exactly the rows the tests use, so the base
    of every nested test is at its minimum."""
    if kind == "gyro":
        fit = _gyro_start(obs)
    else:
        holds = obs.subset(~obs.is_move)
        cal = calibrate_joint(holds.y, holds.R, norm, y_std=holds.sigma * np.sqrt(holds.count)[:, None],
                              counts=holds.count)
        fit = TriadFit(cal.B, cal.H, np.asarray(cal.extra["reference_world"], float), norm)
    return polish(fit, obs)


def _gyro_start(obs: Observations) -> TriadFit:
    """B: mean of the holds (Zhang 2015 eq. 41); H: least squares of the window rates on the raw rates."""
    B = np.average(obs.y[~obs.is_move], axis=0, weights=obs.count[~obs.is_move])
    mv = obs.is_move
    if mv.sum() < 6:
        raise CalibrationError(f"gyro: {int(mv.sum())} move windows; at least 6 are needed to fit H")
    HT, *_ = np.linalg.lstsq(obs.y[mv] - B, obs.rate[mv], rcond=None)
    return TriadFit(B, HT.T, None)
