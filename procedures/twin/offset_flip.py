"""`mag_offset_flip` fitted from a magnetometer's own samples, for a twin without poses (`procedures.twin.gyroless`):
an offset that steps at one instant leaves the calibrated norm off by the step's share along the field,
|u| - F ~ d . c + d^T M d on one side of the instant and d . (c + s) + d^T M d on the other (d the field's
direction; c and M what the calibration's centre and shape, fitted across the step, leave: `compromise`). The
instant is searched on a grid, then row by row about the best; the step is proposed where the regression with it
explains the norm better than without it beyond chance (an F test on the samples' effective number,
`effective_samples`, Bonferroni over the grid) and leaves no change in time (`left_in_time`), and the twin keeps it
only where its replicas bring statistics back (`kept_causes`)."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_distribution

from fixtures.world.effects.mag_offset_flip import MagOffsetFlip
from procedures.twin.cause import Cause
from rig.calibration.recordings.recording import RecordingCalibration
from rig.session_data import SessionData

GRID = 200                 # instants tried, evenly over the middle of the recording
EDGE = 0.05                # share of the recording at either end where no instant is tried
ALPHA = 0.01
REFINE = 4                 # at most this many rounds of taking the step out and calibrating again
GOVERNS = ("mag.norm_residual", "mag.norm_scatter", "mag.norm_mean", "mag.dip_scatter")


@dataclass
class OffsetFlip:
    """A magnetometer's offset step found in a recording: the cause, and the recording with the step taken out of its
    raw samples (`session`) and calibrated again (`rec`), which the twin replays with the cause put back in."""

    cause: Cause
    session: SessionData
    rec: RecordingCalibration


def offset_flip(session: SessionData, rec: RecordingCalibration, norm: float,
                calibrate: Callable[[SessionData], RecordingCalibration]) -> OffsetFlip | None:
    """The magnetometer's offset step, fitted; None where the norm shows none (or too few samples to fit one).

    Found on the recording's calibration, which was fitted across the step (`compromise`); then taken out of the
    raw samples, the recording calibrated again (`calibrate`) and what is left of it fitted at the same instant, a
    few times over: the first-order fit across a compromise misses a step of 3.5 uT by several of its deviations."""
    if "mag" not in rec.sensors or "mag" not in session.raw:
        return None
    y = session.raw["mag"]
    rows = np.flatnonzero(~np.isnan(y).any(axis=1))
    if len(rows) < 10 * GRID:
        return None
    r, d = _norm_residual(rec, y[rows], norm)
    fitted = compromise(d)
    rss0 = _rss(fitted, r)
    grid = np.unique(np.linspace(EDGE * len(rows), (1 - EDGE) * len(rows), GRID).astype(int))
    best = min((_fit_at(k, d, r)[0], k) for k in grid)
    spacing = int(grid[1] - grid[0]) if len(grid) > 1 else 1
    near = range(max(best[1] - spacing, 1), min(best[1] + spacing + 1, len(rows) - 1))   # every row about it
    rss1, k = min([best] + [(_fit_at(j, d, r)[0], j) for j in near])
    step = _fit_at(k, d, r)[1][:3]
    _, _, X = _fit_at(k, d, r)
    left = r - X @ np.linalg.lstsq(X, r, rcond=None)[0]
    dof = effective_samples(left) - X.shape[1]
    if dof < 1:
        return None
    stat = ((rss0 - rss1) / 3.0) / (rss1 / dof)
    p = min(1.0, GRID * float(f_distribution.sf(stat, 3, dof)))
    if p >= ALPHA or left_in_time(left) < ALPHA:
        return None
    step_sd = np.sqrt(np.diag(np.linalg.inv(X.T @ X))[:3] * rss1 / dof)    # at the instant found
    after = np.zeros(len(y), dtype=bool)
    after[rows[k:]] = True
    raw_step, current, corrected = np.zeros(3), rec, session
    for _ in range(REFINE):
        raw_step = raw_step + np.linalg.solve(current.sensors["mag"].H, step)      # u = H (y - B)
        corrected = copy.copy(session)
        corrected.raw = dict(session.raw, mag=y - np.outer(after, raw_step))
        current = calibrate(corrected)
        r, d = _norm_residual(current, corrected.raw["mag"][rows], norm)
        step = _fit_at(k, d, r)[1][:3]
        if np.linalg.norm(step) < 0.1 * np.linalg.norm(step_sd):
            break
    step = current.sensors["mag"].H @ raw_step
    t_flip = float(0.5 * (session.t[rows[k - 1]] + session.t[rows[k]]))
    params = {"t_flip": t_flip, "step_uT": step.tolist(), "step_sd_uT": step_sd.tolist(), "p": p}
    cause = Cause(MagOffsetFlip.name, "mag", float(np.linalg.norm(step)), params, GOVERNS,
                  lambda seed: [MagOffsetFlip("mag", t_flip=t_flip, step=np.array(step))])
    return OffsetFlip(cause, corrected, current)


def _norm_residual(rec: RecordingCalibration, y: np.ndarray, norm: float) -> tuple[np.ndarray, np.ndarray]:
    """|u| - norm and the field's direction d of the complete raw rows y, calibrated as `rec`."""
    u = rec.sensors["mag"].apply(y)
    n = np.linalg.norm(u, axis=1)
    return n - norm, u / n[:, None]


def _fit_at(k: int, d: np.ndarray, r: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The residual sum of squares, coefficients (the step's three first) and design of the step at row k."""
    X = np.hstack([d * (np.arange(len(r)) >= k)[:, None], compromise(d)])
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    return float(np.sum((r - X @ coef) ** 2)), coef, X


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
