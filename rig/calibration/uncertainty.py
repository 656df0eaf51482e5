"""Bootstrap standard deviations of B and H by resampling holds.

Works for any solver (two-step has no analytic covariance); the spread over resampled hold sets also
captures errors the noise model misses (table angle errors, a hold disturbed by vibration).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rig.calibration.result import TriadCalibration
from rig.errors import CalibrationError

MIN_SUCCESS_SHARE = 0.8


def bootstrap_uncertainty(fn: Callable[..., TriadCalibration], y_means: np.ndarray, R: np.ndarray, norm: float, *,
                          n_boot: int = 200, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(B_std (3,), H_std (3, 3)) over `n_boot` resamplings (with replacement) of the holds.

    Resamples that the solver refuses (too few distinct orientations drawn) are skipped; if more than 20 %
    are refused the schedule is too thin for a bootstrap and CalibrationError is raised.
    """
    y = np.asarray(y_means, dtype=float)
    R = np.asarray(R, dtype=float)
    rng = np.random.default_rng(seed)
    Bs, Hs = [], []
    for _ in range(n_boot):
        idx = rng.integers(0, len(y), len(y))
        try:
            cal = fn(y[idx], R[idx], norm)
        except CalibrationError:
            continue
        Bs.append(cal.B)
        Hs.append(cal.H)
    if len(Bs) < MIN_SUCCESS_SHARE * n_boot or len(Bs) < 2:
        raise CalibrationError(f"bootstrap: only {len(Bs)} of {n_boot} resamples could be calibrated; "
                               "too few or too similar orientations for a bootstrap")
    return np.std(Bs, axis=0, ddof=1), np.std(Hs, axis=0, ddof=1)
