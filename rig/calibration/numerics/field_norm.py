"""A magnetometer calibrated to the field magnitude its own samples show, where the recording does not say the
local one (no `field_uT`).

The samples fix the ellipsoid, so the map `S` onto the unit sphere (`|S (y - B)| = 1`), but not how many uT that
sphere's radius is: any `H = N S` fits them as well. The convention taken is `det(H) = 1` in the raw unit: the
soft iron is taken to keep the volume of the sphere (a sensor whose three scales are off by +3, -1 and -2 %
reads the field 0.02 % low), so `N = det(S)^(-1/3)`, the geometric mean of the ellipsoid's semi-axes. In a raw
unit of field (uT, or gauss and mG as imported) N is the local field to within the soft iron's mean scale; in
counts it is the sphere's radius in counts, and so is the calibrated output.

The covariance follows H through the normalisation (delta method): with `d = det(H)`,
`dH' = d^(-1/3) (dH - H tr(H^-1 dH) / 3)` and `dN = -N tr(H^-1 dH) / 3`, `d det(H) = det(H) tr(H^-1 dH)`
(Jacobi's formula).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class DataField:
    """H scaled to det(H) = 1, its covariance, and the field magnitude that makes (N and its deviation)."""

    H: np.ndarray          # (3, 3)
    H_cov: np.ndarray      # (9, 9) row-major vec(H)
    B_H_cov: np.ndarray | None   # (3, 9) between B and vec(H), where the fit gave it
    field: float
    field_std: float


def to_data_field(H: np.ndarray, norm: float, H_cov: np.ndarray, B_H_cov: np.ndarray | None = None) -> DataField:
    """H fitted to a field of magnitude `norm` (any: the one the fit started from), with its covariance (9, 9) and
    its covariance with B (3, 9), rescaled to det(H) = 1; the field magnitude in the raw unit that gives."""
    H = np.asarray(H, dtype=float)
    d = float(np.linalg.det(H))
    if not d > 0:
        raise ValueError(f"det(H) = {d:.3g}: not a proper map of the field")
    k = d ** (-1.0 / 3.0)
    trace_row = np.linalg.inv(H).T.ravel()                   # tr(H^-1 dH) = vec(H^-T) . vec(dH)
    L = k * (np.eye(9) - np.outer(H.ravel(), trace_row) / 3.0)
    field = norm * k
    g = -field / 3.0 * trace_row
    return DataField(H=H * k, H_cov=L @ H_cov @ L.T, B_H_cov=None if B_H_cov is None else B_H_cov @ L.T,
                     field=field, field_std=float(np.sqrt(max(g @ H_cov @ g, 0.0))))


def data_field_norm(S: np.ndarray) -> float:
    """The field magnitude N = det(S)^(-1/3) of a map S onto the unit sphere."""
    return float(np.linalg.det(S)) ** (-1.0 / 3.0)
