"""Ordinary least squares with its nested F test: the one regression test behind the effects a recording's pose
means show, whether the discrepancy analysis names them (`rig.discrepancy.recording`) or the calibration takes
one into its model (`rig.calibration.recordings.g_sensitivity`)."""

from __future__ import annotations

import numpy as np
from scipy.special import fdtrc


def nested_f(X_full: np.ndarray, X_red: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """p of the nested F test (all response columns pooled), the full model's coefficients and (X^T X)^-1."""
    n, p_full = X_full.shape
    coef, *_ = np.linalg.lstsq(X_full, y, rcond=None)
    red, *_ = np.linalg.lstsq(X_red, y, rcond=None)
    rss_full = float(np.sum((y - X_full @ coef) ** 2))
    rss_red = float(np.sum((y - X_red @ red) ** 2))
    q = (p_full - X_red.shape[1]) * y.shape[1]
    dof = (n - p_full) * y.shape[1]
    if dof <= 0 or rss_full <= 0:
        return 1.0, coef, np.linalg.pinv(X_full.T @ X_full)
    F = ((rss_red - rss_full) / q) / (rss_full / dof)
    return float(fdtrc(q, dof, F)), coef, np.linalg.pinv(X_full.T @ X_full)


def resvar(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residual variance of each response column under X."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return np.sum((y - X @ coef) ** 2, axis=0) / max(len(y) - X.shape[1], 1)
