"""LAPACK for the small dense problems of the vector solvers (3x3 and 9x9), through numpy's own bindings.

The two-step and ellipsoid solves decompose a handful of tiny matrices each and are timed in fractions of
a millisecond; numpy.linalg's public functions spend three to five times the arithmetic on argument checks
there. scipy.linalg.lapack skipped those checks but costs ~0.14 s to import, a third of what a whole
`rig calibrate --from` may take (issue 17, start-up). So the functions below call the gufuncs numpy.linalg
itself calls (`numpy.linalg._umath_linalg`: LAPACK dsyevd, dgesv), falling back to the public
functions if a numpy release ever drops them. A failed decomposition gives NaN, as numpy's gufuncs do,
for the caller to refuse; tests/startup/test_small_lapack.py holds the results equal to scipy's LAPACK.
"""

from __future__ import annotations

import math

import numpy as np

try:
    from numpy.linalg import _umath_linalg as _gufuncs

    _eigh, _eigvalsh, _solve, _solve1, _inv = (_gufuncs.eigh_lo, _gufuncs.eigvalsh_lo, _gufuncs.solve,
                                              _gufuncs.solve1, _gufuncs.inv)
except (ImportError, AttributeError):          # the public functions: same LAPACK, slower, raise on failure
    _eigh, _eigvalsh, _inv = np.linalg.eigh, np.linalg.eigvalsh, np.linalg.inv
    _solve = _solve1 = np.linalg.solve


def symmetric_eigen(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and eigenvectors (columns) of the finite symmetric A (its lower triangle is read).

    NaN in the rare case LAPACK does not converge."""
    try:
        return _eigh(A)
    except np.linalg.LinAlgError:
        n = A.shape[-1]
        return np.full(n, np.nan), np.full((n, n), np.nan)


def symmetric_eigenvalues(A: np.ndarray) -> np.ndarray:
    """Eigenvalues (ascending) of the finite symmetric A; NaN if LAPACK does not converge."""
    try:
        return _eigvalsh(A)
    except np.linalg.LinAlgError:
        return np.full(A.shape[-1], np.nan)


def solve(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """X with A X = B (B a vector or a matrix) for a nonsingular A, by LU with partial pivoting.

    For a caller that has already refused a singular A: one that is singular after all gives NaN (and
    numpy's warning) rather than an exception."""
    try:
        return (_solve1 if B.ndim == 1 else _solve)(A, B)
    except np.linalg.LinAlgError:
        return np.full(B.shape, np.nan)


def solve_with_condition(A: np.ndarray, b: np.ndarray, norm_A: float) -> tuple[np.ndarray, float]:
    """(x with A x = b, 1 / (norm_A ||A^-1||_1)) for a small A: the reciprocal condition number LAPACK's
    dpocon estimates, here exact from the inverse that also gives x (NaN and 0 for a singular A)."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        try:
            inv = _inv(A)
        except np.linalg.LinAlgError:
            return np.full(b.shape, np.nan), 0.0
        norm_inv = float(np.abs(inv).sum(axis=0).max())
    if not (math.isfinite(norm_inv) and norm_inv > 0):
        return np.full(b.shape, np.nan), 0.0
    return inv @ b, 1.0 / (norm_A * norm_inv)
