"""The steps of a thermal session with their sweep direction and die-temperature rate, and the temperature curves
fitted to them with a sweep offset and a lag.

Each step k gives six terms z_k: B's three elements (counts) and H's three scales (H_ii relative to its mean over
the steps), with their covariance C_k (B_cov and the scales' block of H_cov). The curves are those of the
temperature model (rig.calibration.thermal), each term a polynomial P_i of the die temperature, here at the
highest order the model ever takes (polynomial.MAX_ORDER; less where the distinct set points, up and down counted
once, do not allow it) so that a curve the model could follow is never read as a cause. The extensions:

    z_k = P(T_k - r_k tau) + s_k h + e_k,       e_k ~ N(0, C_k + sigma_Tk^2 g_k g_k'),

s_k = +1 on the up sweep, -1 on the down sweep, h the half-width of the hysteresis (one per term: B_up(T) =
B(T) + h, B_down(T) = B(T) - h), r_k the die temperature's rate during the step's holds and tau the lag of the
sensing element's temperature behind the thermometer's. The die temperature's spread sigma_Tk moves each term by
its slope g_k (effective variance, Orear 1982, as rig.calibration.thermal.curves does; the slopes from a first fit
with the sweep offset, so that an offset does not bend them). For a given tau the model
is linear in the polynomials and h, solved by generalised least squares; tau is found by minimising the profile
chi-square over a bracket, and its deviation from the linearised model at the minimum (the column
dz_k/dtau = -r_k P'(T_k - r_k tau)), the covariance scaled by the reduced chi-square where that exceeds 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from rig.calibration.thermal import ThermalStep
from rig.calibration.thermal.curves import step_covariance
from rig.calibration.thermal.polynomial import MAX_ORDER, derivative_design, design

SWEEPS = {"up": 1.0, "down": -1.0}
SCALES = [0, 4, 8]                 # H row-major: the diagonal
TAU_GRID = 41
LAG_REACH = 0.25                   # the lag searched moves no step by more than this share of the temperature range
TAU_LIMIT_S = 1800.0
SAME_SET_POINT_C = 1.0             # steps closer than this are one temperature to the curves' order


@dataclass
class SweptStep:
    """One step of a thermal session as the thermal causes need it: the step (die temperature, its spread, the
    calibration made there), the direction of the sweep it belongs to ("up" or "down"), the die temperature's
    rate of change during its holds (degC per minute, signed: rising is positive) and the chamber air's
    temperature (degC, None where the session did not read it)."""

    step: ThermalStep
    sweep: str
    rate_c_per_min: float
    air_c: float | None = None


@dataclass
class SweepData:
    """The steps' terms, normalised per term to about unit deviation (`unit`: what one normalised unit is in the
    term's own unit: counts for B, relative scale for the scales)."""

    temp_c: np.ndarray
    temp_std_c: np.ndarray
    sign: np.ndarray
    rate_c_per_s: np.ndarray
    Z: np.ndarray
    C: np.ndarray
    unit: np.ndarray
    H_mean: np.ndarray
    reference_c: float
    half_range_c: float
    order: int
    set_points: int


@dataclass
class SweepFit:
    """One model fitted: the chi-square, its degrees of freedom, tau (s, 0 without lag) and the hysteresis h
    (normalised terms, None without), with the covariance of (h, tau) scaled as the module docstring says."""

    chi2: float
    dof: int
    tau_s: float
    h: np.ndarray | None
    cov_h: np.ndarray | None
    tau_std_s: float


def sweep_data(sensor: str, steps: list[SweptStep]) -> SweepData:
    """The steps' terms and covariances; a step that says no sweep, or no finite rate, is refused by name."""
    if len(steps) < 3:
        raise ValueError(f"sensor {sensor!r}: the thermal causes need 3 or more steps, got {len(steps)}")
    for i, s in enumerate(steps):
        where = f"sensor {sensor!r}, step {i} at {s.step.temp_c} C"
        if s.sweep not in SWEEPS:
            raise ValueError(f"{where}: sweep must be one of {sorted(SWEEPS)}, got {s.sweep!r}")
        if not np.isfinite(s.rate_c_per_min):
            raise ValueError(f"{where}: rate_c_per_min must be a finite number, got {s.rate_c_per_min!r}")
        if not np.isfinite(s.step.temp_c):
            raise ValueError(f"{where}: temp_c must be a finite number")
    T = np.array([s.step.temp_c for s in steps], dtype=float)
    cals = [s.step.calibration for s in steps]
    H = np.stack([np.asarray(c.H, dtype=float) for c in cals])
    H_mean = H.mean(axis=0)
    diag = np.abs(np.diag(H_mean))
    Zraw = np.hstack([np.stack([np.asarray(c.B, dtype=float) for c in cals]), H.reshape(-1, 9)[:, SCALES] / diag])
    Craw = np.zeros((len(steps), 6, 6))
    for k, (s, c) in enumerate(zip(steps, cals)):
        where = f"sensor {sensor!r}, step at {s.step.temp_c} C"
        Craw[k, :3, :3] = step_covariance(c.B_cov, c.B_std, 3, f"{where}, B")
        CH = step_covariance(c.H_cov, c.H_std, 9, f"{where}, H")
        Craw[k, 3:, 3:] = CH[np.ix_(SCALES, SCALES)] / np.outer(diag, diag)
    Zraw[:, 3:] -= np.sign(np.diag(H_mean))
    unit = np.sqrt(np.median(np.einsum("kii->ki", Craw), axis=0))
    distinct = 1 + int(np.sum(np.diff(np.sort(T)) > SAME_SET_POINT_C))
    return SweepData(temp_c=T, temp_std_c=np.array([s.step.temp_std_c for s in steps], dtype=float),
                     sign=np.array([SWEEPS[s.sweep] for s in steps]),
                     rate_c_per_s=np.array([s.rate_c_per_min for s in steps], dtype=float) / 60.0,
                     Z=Zraw / unit, C=Craw / np.outer(unit, unit)[None], unit=unit, H_mean=H_mean,
                     reference_c=0.5 * (T.min() + T.max()), half_range_c=max(0.5 * float(np.ptp(T)), 1e-6),
                     order=int(max(0, min(MAX_ORDER, distinct - 1))), set_points=distinct)


class SweepModel:
    """The fits of one sensor's steps (module docstring): with or without hysteresis, with or without lag."""

    def __init__(self, d: SweepData) -> None:
        self.d = d
        self.q_poly = 6 * (d.order + 1)
        self._weigh(d.C)
        both_sweeps = bool(np.any(d.sign > 0) and np.any(d.sign < 0))
        self.slopes = self._slopes(self._solve(0.0, both_sweeps)[0], 0.0)
        self._weigh(d.C + d.temp_std_c[:, None, None] ** 2 * np.einsum("ki,kj->kij", self.slopes, self.slopes))

    def _weigh(self, V: np.ndarray) -> None:
        """Per step, W with W' W = V^-1 (W = L^-1 for V = L L'): whitened residuals have unit covariance."""
        self.W = np.linalg.inv(np.linalg.cholesky(V))
        self.Zw = np.einsum("kij,kj->ki", self.W, self.d.Z).ravel()

    def _x(self, tau: float) -> np.ndarray:
        d = self.d
        return (d.temp_c - d.rate_c_per_s * tau - d.reference_c) / d.half_range_c

    def _blocks(self, tau: float, with_h: bool, lag_column: np.ndarray | None = None) -> np.ndarray:
        d = self.d
        x = self._x(tau)
        P = design(x, d.order)
        q = self.q_poly + (6 if with_h else 0) + (1 if lag_column is not None else 0)
        A = np.zeros((len(x), 6, q))
        for i in range(6):
            A[:, i, i * (d.order + 1):(i + 1) * (d.order + 1)] = P
        if with_h:
            A[:, :, self.q_poly:self.q_poly + 6] = d.sign[:, None, None] * np.eye(6)[None]
        if lag_column is not None:
            A[:, :, -1] = lag_column
        return A

    def _slopes(self, theta: np.ndarray, tau: float) -> np.ndarray:
        """dz/dT of each term at each step's (shifted) temperature, per degC: (steps, 6)."""
        d = self.d
        D = derivative_design(self._x(tau), d.order) / d.half_range_c
        c = theta[:self.q_poly].reshape(6, d.order + 1)
        return D @ c.T

    def _solve(self, tau: float, with_h: bool, lag_column: np.ndarray | None = None):
        """Coefficients, their covariance (unscaled), chi-square and their count, at one tau."""
        Aw = self._whitened(tau, with_h, lag_column)
        theta = np.linalg.lstsq(Aw, self.Zw, rcond=None)[0]
        r = self.Zw - Aw @ theta
        return theta, np.linalg.pinv(Aw.T @ Aw), float(r @ r), Aw.shape[1]

    def _chi2(self, tau: float, with_h: bool) -> float:
        Aw = self._whitened(tau, with_h, None)
        r = self.Zw - Aw @ np.linalg.lstsq(Aw, self.Zw, rcond=None)[0]
        return float(r @ r)

    def _whitened(self, tau: float, with_h: bool, lag_column: np.ndarray | None) -> np.ndarray:
        A = self._blocks(tau, with_h, lag_column)
        return np.matmul(self.W, A).reshape(-1, A.shape[2])

    def tau_bound_s(self) -> float:
        """The largest lag searched (s): none moves a step by more than LAG_REACH of the range; 0 without rates."""
        top = float(np.max(np.abs(self.d.rate_c_per_s)))
        if top <= 0:
            return 0.0
        return float(min(TAU_LIMIT_S, LAG_REACH * 2 * self.d.half_range_c / top))

    def fit(self, with_h: bool, with_lag: bool) -> SweepFit:
        """One of the four models: tau by the profile chi-square (a grid over +-tau_bound_s, refined around its
        best point), then h and the deviations at that tau (module docstring)."""
        n_obs = self.d.Z.size
        tau = 0.0
        if with_lag and self.tau_bound_s() > 0:
            bound = self.tau_bound_s()
            grid = np.linspace(-bound, bound, TAU_GRID)
            chi = [self._chi2(t, with_h) for t in grid]
            i = int(np.argmin(chi))
            lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, TAU_GRID - 1)]
            best = minimize_scalar(lambda t: self._chi2(t, with_h), bounds=(lo, hi), method="bounded",
                                   options={"xatol": 1e-6 * bound})
            tau = float(best.x) if best.fun <= chi[i] else float(grid[i])
        theta, cov, chi2, q = self._solve(tau, with_h)
        tau_std = float("nan")
        if with_lag:
            column = -self.d.rate_c_per_s[:, None] * self._slopes(theta, tau)
            _, cov, _, q = self._solve(tau, with_h, column)
            tau_std = float(np.sqrt(max(cov[-1, -1], 0.0)))
        dof = n_obs - q
        scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
        h = cov_h = None
        if with_h:
            h = theta[self.q_poly:self.q_poly + 6]
            cov_h = cov[self.q_poly:self.q_poly + 6, self.q_poly:self.q_poly + 6] * scale
        return SweepFit(chi2=chi2, dof=dof, tau_s=tau, h=h, cov_h=cov_h, tau_std_s=tau_std * np.sqrt(scale))

    def lag_inflation(self) -> float:
        """How much the lag's deviation grows when the hysteresis is fitted beside it, at no lag (sqrt of the
        variance inflation factor of the lag column given the curves and the sweep offsets): about 1 where the
        steps' rates tell lag from hysteresis, large where the lag column is (nearly) a sweep offset."""
        column = -self.d.rate_c_per_s[:, None] * self.slopes
        if not np.any(column):
            return float("inf")
        alone = self._solve(0.0, False, column)[1][-1, -1]
        beside = self._solve(0.0, True, column)[1][-1, -1]
        return float(np.sqrt(beside / alone)) if alone > 0 else float("inf")

