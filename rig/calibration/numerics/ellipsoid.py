"""Linear least-squares ellipsoid through raw accelerometer/magnetometer points.

Zhang et al. 2015, section II.B, eqs. 15-17 (equation numbers as given in the project brief; the paper's
text could not be retrieved, so the formulation below is the standard algebraic fit, reconstructed):
every calibrated static reading has the same magnitude, so the raw points lie on an ellipsoid
`(y - B)^T A (y - B) = 1` whose centre is the combined bias B. The quadric
`y^T M y + 2 m^T y = 1` is linear in its nine coefficients, hence one least-squares solve.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from rig.errors import CalibrationError

MIN_POINTS = 9
DISTINCT_RADIUS = 0.02   # in units of the RMS spread of the points: ~1 deg of orientation
MIN_RCOND = 1e-13        # of the 9x9 normal matrix: singular-value ratio of the design below ~3e-7 is degenerate
SPREAD_RATIO_MIN = 0.05  # smallest/largest singular value of a spread (points, directions) below which it is flat
_QI, _QJ = np.array([0, 1, 2, 0, 0, 1, 0, 1, 2]), np.array([0, 1, 2, 1, 2, 2, 3, 3, 3])
_QW = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0])
_SYM = np.array([0, 3, 4, 3, 1, 5, 4, 5, 2])


@dataclass
class EllipsoidFit:
    center: np.ndarray    # (3,) B, raw counts
    axes: tuple[np.ndarray, np.ndarray]   # eigenvalues (ascending), eigenvectors (columns) of `shape`
    residual: float       # RMS of (y - B)^T A (y - B) - 1 (dimensionless)

    @property
    def shape(self) -> np.ndarray:
        """(3, 3) A, SPD: (y - B)^T A (y - B) = 1."""
        w, V = self.axes
        return (V * w) @ V.T


def fit_ellipsoid(y: np.ndarray, *, what: str = "ellipsoid fit", check_repeats: bool = True,
                  min_spread: float = SPREAD_RATIO_MIN) -> EllipsoidFit:
    """Algebraic ellipsoid fit (eqs. 15-17) through n >= 9 non-coplanar points y (n, 3).

    The points are centred on their mean and scaled before the solve: this keeps the origin inside the
    ellipsoid (so the right-hand side `1` is a valid normalisation) and the design matrix well conditioned
    for raw counts of any magnitude, which is also what lets the normal equations stand in for lstsq.
    check_repeats=False skips the repeated-point count, for callers that check repeats more strictly
    themselves (the two-step method counts the noise-free reference directions of its known rotations).
    min_spread: smallest/largest singular value of the centred points below which they count as coplanar and
    are refused (a flat cap of noisy points gives a wrong centre); 0 accepts any spread, for a fit that only
    starts an optimiser.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 2 or y.shape[1] != 3:
        raise CalibrationError(f"{what}: expected points of shape (n, 3), got {y.shape}")
    n = y.shape[0]
    if n < MIN_POINTS:
        raise CalibrationError(f"{what}: {n} points, need at least {MIN_POINTS}")
    if not np.isfinite(y).all():
        bad = np.flatnonzero(~np.isfinite(y).all(axis=1))
        raise CalibrationError(f"{what}: non-finite values in rows {bad.tolist()}")
    mean = y.sum(axis=0) / n
    yc = y - mean
    scale = np.sqrt(refuse_coplanar(yc.T @ yc, what, min_spread).sum() / n)
    p1 = np.ones((n, 4))
    np.divide(yc, scale, out=p1[:, :3])
    if check_repeats:
        _refuse_repeats(p1[:, :3], what)
    D = p1.take(_QI, axis=1) * p1.take(_QJ, axis=1) * _QW   # x1^2 x2^2 x3^2 2x1x2 2x1x3 2x2x3 2x
    c = _solve_normal_equations(D, what)
    M = c.take(_SYM).reshape(3, 3)
    w, V = np.linalg.eigh(M)
    if not (np.isfinite(w).all() and w[-1] > 0):
        raise CalibrationError(f"{what}: singular quadric, the points do not bound an ellipsoid")
    centre_p = -V @ ((V.T @ c[6:]) / w)               # M centre = -m
    k = 1.0 - float(centre_p @ c[6:])                 # 1 + centre^T M centre
    if not (k > 0 and w[0] > 0):
        raise CalibrationError(f"{what}: the fitted quadric is not an ellipsoid (shape matrix not positive "
                               "definite); too few or badly spread orientations, or outliers")
    r = D @ c - 1.0                                   # = (q^T A_p q - 1) k with q = p - centre
    residual = float(np.sqrt(np.vdot(r, r) / n)) / k
    return EllipsoidFit(center=mean + scale * centre_p, axes=(w / (k * scale * scale), V), residual=residual)


def refuse_coplanar(scatter: np.ndarray, what: str, min_spread: float = SPREAD_RATIO_MIN) -> np.ndarray:
    """Raw points on a plane (affinely) cannot fix an ellipsoid: refuse rather than return a wrong H.

    scatter is `yc^T yc` of the centred points; returns its eigenvalues (ascending) for the caller's use.
    """
    w = np.linalg.eigvalsh(scatter)
    if not w[2] > 0:
        raise CalibrationError(f"{what}: all points are identical")
    ratio = np.sqrt(max(w[0], 0.0) / w[2])            # of the singular values of the centred points
    if ratio < min_spread:
        raise CalibrationError(f"{what}: the orientations are coplanar (raw readings lie on a plane, spread ratio "
                               f"{ratio:.3g}); one sensor direction is never excited — check the schedule "
                               "with observability.check_schedule")
    return w


def _refuse_repeats(p: np.ndarray, what: str) -> None:
    distinct = count_distinct_points(p)
    if distinct < MIN_POINTS:
        raise CalibrationError(f"{what}: only {distinct} distinct orientations among {len(p)} points "
                               f"(repeats within {DISTINCT_RADIUS:g} of the spread count once); the ellipsoid "
                               f"needs {MIN_POINTS}")


def _solve_normal_equations(D: np.ndarray, what: str) -> np.ndarray:
    """Least-squares coefficients of D c = 1 from the normal equations, refusing a degenerate D.

    The reciprocal condition number is 1 / (||A||_1 ||A^-1||_1), the one LAPACK's dpocon estimates (infinite
    condition for a singular A)."""
    DtD = D.T @ D
    if not 1.0 / np.linalg.cond(DtD, 1) >= MIN_RCOND:
        raise CalibrationError(f"{what}: the points are degenerate (coplanar or on a conic); "
                               "add orientations that tilt every sensor axis")
    return np.linalg.solve(DtD, D.sum(axis=0))


def count_distinct_points(p: np.ndarray, radius: float = DISTINCT_RADIUS) -> int:
    """Points not within `radius` of an earlier point: a repeated hold adds no shape information."""
    sq = np.einsum("ij,ij->i", p, p)
    d2 = sq[:, None] + sq[None, :] - 2.0 * (p @ p.T)
    close = (d2 < radius * radius) & later_pairs(len(p))
    return len(p) - int(np.count_nonzero(close.any(axis=0)))


@lru_cache(maxsize=64)
def later_pairs(n: int) -> np.ndarray:
    """Read-only mask of pairs (i, j) with i < j, cached: building it costs more than the comparison it masks."""
    mask = np.triu(np.ones((n, n), dtype=bool), 1)
    mask.flags.writeable = False
    return mask


def sphere_map(fit: EllipsoidFit, norm: float) -> np.ndarray:
    """Symmetric H = norm * A^(1/2): maps the ellipsoid onto the sphere of radius `norm`.

    Only the symmetric square root is defined by the ellipsoid; any rotation of it fits equally well,
    which is why a second step with known rotations is needed for the mounting.
    """
    w, V = fit.axes
    return norm * (V * np.sqrt(w)) @ V.T
