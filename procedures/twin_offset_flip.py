"""`mag_offset_flip` fitted from a magnetometer's own samples, for a twin without poses (`procedures.twin_gyroless`):
an offset that steps at one instant leaves the calibrated norm off by the step's share along the field,
|u| - F ~ d . c + d^T M d on one side of the instant and d . (c + s) + d^T M d on the other (d the field's
direction; c and M what the calibration's centre and shape, fitted across the step, leave: `compromise`). The instant is searched on a grid; the step is proposed
where the regression with it explains the norm better than without it beyond chance (an F test on the samples'
effective number, `effective_samples`, Bonferroni over the grid) and leaves no change in time (`left_in_time`),
and the twin keeps it only where its replicas bring statistics back (`kept_causes`)."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_distribution

from fixtures.world.effects.mag_offset_flip import MagOffsetFlip
from procedures.twin_cause import Cause
from rig.calibration.recording import RecordingCalibration
from rig.session_data import SessionData

GRID = 200                 # instants tried, evenly over the middle of the recording
EDGE = 0.05                # share of the recording at either end where no instant is tried
ALPHA = 0.01
GOVERNS = ("mag.norm_residual", "mag.norm_scatter", "mag.norm_mean", "mag.dip_scatter")


def offset_flip_cause(session: SessionData, rec: RecordingCalibration, norm: float) -> Cause | None:
    """The magnetometer's offset step, fitted, as a cause; None where the norm shows none (or nothing to fit)."""
    if "mag" not in rec.sensors or "mag" not in session.raw:
        return None
    y = session.raw["mag"]
    rows = np.flatnonzero(~np.isnan(y).any(axis=1))
    if len(rows) < 10 * GRID:
        return None
    u = rec.sensors["mag"].apply(y[rows])
    n = np.linalg.norm(u, axis=1)
    d = u / n[:, None]
    r = n - norm
    fitted = compromise(d)
    rss0 = _rss(fitted, r)
    best = None
    for k in np.unique(np.linspace(EDGE * len(rows), (1 - EDGE) * len(rows), GRID).astype(int)):
        X = np.hstack([d * (np.arange(len(rows)) >= k)[:, None], fitted])
        coef, *_ = np.linalg.lstsq(X, r, rcond=None)
        rss = float(np.sum((r - X @ coef) ** 2))
        if best is None or rss < best[0]:
            best = (rss, k, coef[:3])
    rss1, k, step = best
    X = np.hstack([d * (np.arange(len(rows)) >= k)[:, None], fitted])
    dof = effective_samples(r - X @ np.linalg.lstsq(X, r, rcond=None)[0]) - X.shape[1]
    if dof < 1:
        return None
    stat = ((rss0 - rss1) / 3.0) / (rss1 / dof)
    p = min(1.0, GRID * float(f_distribution.sf(stat, 3, dof)))
    left = r - X @ np.linalg.lstsq(X, r, rcond=None)[0]
    if p >= ALPHA or left_in_time(left) < ALPHA:
        return None
    t_flip = float(0.5 * (session.t[rows[k - 1]] + session.t[rows[k]]))
    step_sd = np.sqrt(np.diag(np.linalg.inv(X.T @ X))[:3] * rss1 / dof)    # at the instant found
    params = {"t_flip": t_flip, "step_uT": step.tolist(), "step_sd_uT": step_sd.tolist(), "p": p}
    return Cause("mag_offset_flip", "mag", float(np.linalg.norm(step)), params, GOVERNS,
                 lambda seed: [MagOffsetFlip("mag", t_flip=t_flip, step=np.array(step))])


def compromise(d: np.ndarray) -> np.ndarray:
    """(n, 9) what a calibration fitted across the step can leave of the norm along the field's directions d (n, 3),
    to first order: a centre off (d . c) and a scale and shape off (d^T M d, M symmetric; its trace is the
    constant)."""
    x, y, z = d.T
    return np.column_stack([d, x * x, y * y, z * z, x * y, x * z, y * z])


def left_in_time(residual: np.ndarray, slices: int = 10) -> float:
    """The chance that what the step leaves of the norm changes over the recording's tenths no more than its own
    scatter gives (chi-square of the tenths' means against their standard errors): a step explains a change in time
    only where nothing is left of it. A hand-turned magnetometer's norm wanders with what the linear model misses
    of it, and a step fitted to that wandering explains one tenth of it and leaves the rest."""
    parts = np.array_split(residual - residual.mean(), slices)
    sd = residual.std(ddof=1)
    stat = sum(len(p) * p.mean() ** 2 for p in parts) / sd ** 2 if sd > 0 else 0.0
    return float(chi2.sf(stat, slices - 1))


def effective_samples(residual: np.ndarray) -> float:
    """How many independent samples the residuals are worth: n (1 - rho) / (1 + rho) for their lag-one
    autocorrelation rho (an AR(1) reading). What the linear model misses of a hand's turns drifts slowly, sample to
    sample; counted as n independent ones it would make any change in time significant."""
    e = residual - residual.mean()
    rho = float(np.clip((e[1:] @ e[:-1]) / (e @ e), 0.0, 0.999)) if e @ e > 0 else 0.0
    return len(e) * (1.0 - rho) / (1.0 + rho)


def _rss(X: np.ndarray, r: np.ndarray) -> float:
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    return float(np.sum((r - X @ coef) ** 2))
