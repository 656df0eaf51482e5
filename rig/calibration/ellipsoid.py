"""Linear least-squares ellipsoid through raw accelerometer/magnetometer points.

Zhang et al. 2015, section II.B, eqs. 15-17 (equation numbers as given in the project brief; the paper's
text could not be retrieved, so the formulation below is the standard algebraic fit, reconstructed):
every calibrated static reading has the same magnitude, so the raw points lie on an ellipsoid
`(y - B)^T A (y - B) = 1` whose centre is the combined bias B. The quadric
`y^T M y + 2 m^T y = 1` is linear in its nine coefficients, hence one least-squares solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.errors import CalibrationError

MIN_POINTS = 9
DISTINCT_RADIUS = 0.02   # in units of the RMS spread of the points: ~1 deg of orientation
_QI, _QJ, _QW = [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2], np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])


@dataclass
class EllipsoidFit:
    center: np.ndarray    # (3,) B, raw counts
    shape: np.ndarray     # (3, 3) A, SPD: (y - B)^T A (y - B) = 1
    residual: float       # RMS of (y - B)^T A (y - B) - 1 (dimensionless)


def fit_ellipsoid(y: np.ndarray) -> EllipsoidFit:
    """Algebraic ellipsoid fit (eqs. 15-17) through n >= 9 non-coplanar points y (n, 3).

    The points are centred on their mean and scaled before the solve: this keeps the origin inside the
    ellipsoid (so the right-hand side `1` is a valid normalisation) and the design matrix well conditioned
    for raw counts of any magnitude.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 2 or y.shape[1] != 3:
        raise CalibrationError(f"ellipsoid fit: expected points of shape (n, 3), got {y.shape}")
    if y.shape[0] < MIN_POINTS:
        raise CalibrationError(f"ellipsoid fit: {y.shape[0]} points, need at least {MIN_POINTS}")
    bad = np.flatnonzero(~np.isfinite(y).all(axis=1))
    if bad.size:
        raise CalibrationError(f"ellipsoid fit: non-finite values in rows {bad.tolist()}")
    mean = y.mean(axis=0)
    scale = np.sqrt(((y - mean) ** 2).sum(axis=1).mean())
    if not scale > 0:
        raise CalibrationError("ellipsoid fit: all points are identical")
    p = (y - mean) / scale
    distinct = _count_distinct_points(p)
    if distinct < MIN_POINTS:
        raise CalibrationError(f"ellipsoid fit: only {distinct} distinct orientations among {len(p)} points "
                               f"(repeats within {DISTINCT_RADIUS:g} of the spread count once); the ellipsoid "
                               f"needs {MIN_POINTS}")
    D = np.concatenate((p[:, _QI] * p[:, _QJ] * _QW, 2 * p), axis=1)   # x1^2 x2^2 x3^2 2x1x2 2x1x3 2x2x3 2x
    c, _, rank, sv = np.linalg.lstsq(D, np.ones(len(p)), rcond=None)
    if rank < 9 or sv[-1] < 1e-9 * sv[0]:
        raise CalibrationError("ellipsoid fit: the points are degenerate (coplanar or on a conic); "
                               "add orientations that tilt every sensor axis")
    M = np.array([[c[0], c[3], c[4]], [c[3], c[1], c[5]], [c[4], c[5], c[2]]])
    m = c[6:9]
    try:
        centre_p = -np.linalg.solve(M, m)
    except np.linalg.LinAlgError as exc:
        raise CalibrationError("ellipsoid fit: singular quadric, the points do not bound an ellipsoid") from exc
    k = 1.0 + centre_p @ M @ centre_p
    A_p = M / k
    if not np.all(np.linalg.eigvalsh(A_p) > 0):
        raise CalibrationError("ellipsoid fit: the fitted quadric is not an ellipsoid (shape matrix not "
                               "positive definite); too few or badly spread orientations, or outliers")
    q = p - centre_p
    residual = float(np.sqrt(np.mean((np.einsum("ni,ij,nj->n", q, A_p, q) - 1.0) ** 2)))
    return EllipsoidFit(center=mean + scale * centre_p, shape=A_p / scale**2, residual=residual)


def _count_distinct_points(p: np.ndarray) -> int:
    """Points not within DISTINCT_RADIUS of an earlier point: a repeated hold adds no shape information."""
    sq = np.einsum("ij,ij->i", p, p)
    d2 = sq[:, None] + sq[None, :] - 2.0 * (p @ p.T)
    close = np.triu(d2 < DISTINCT_RADIUS**2, 1)
    return int(len(p) - np.count_nonzero(close.any(axis=0)))


def sphere_map(fit: EllipsoidFit, norm: float) -> np.ndarray:
    """Symmetric H = norm * A^(1/2): maps the ellipsoid onto the sphere of radius `norm`.

    Only the symmetric square root is defined by the ellipsoid; any rotation of it fits equally well,
    which is why a second step with known rotations is needed for the mounting.
    """
    w, V = np.linalg.eigh(fit.shape)
    return norm * (V * np.sqrt(w)) @ V.T
