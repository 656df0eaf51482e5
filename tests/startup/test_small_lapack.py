"""rig.calibration.small_lapack against scipy's LAPACK bindings, which the vector solvers called before."""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from rig.calibration import small_lapack


def _spd(rng: np.random.Generator, n: int, spread: float) -> np.ndarray:
    A = rng.normal(size=(n + 3, n)) * 10.0 ** rng.uniform(-spread, spread, n)
    return A.T @ A


def test_symmetric_eigen_equals_dsyev():
    rng = np.random.default_rng(41)
    for n in (3, 9):
        for spread in (0.0, 1.0, 3.0):
            for _ in range(50):
                A = _spd(rng, n, spread) - (rng.uniform() < 0.3) * np.eye(n)       # some indefinite
                w_ref, V_ref, info = lapack.dsyev(A)
                assert info == 0
                w, V = small_lapack.symmetric_eigen(A)
                scale = np.abs(w_ref).max()
                np.testing.assert_allclose(w, w_ref, rtol=0, atol=1e-13 * scale)
                np.testing.assert_allclose(small_lapack.symmetric_eigenvalues(A), w_ref, rtol=0, atol=1e-13 * scale)
                np.testing.assert_allclose((V * w) @ V.T, A, rtol=0, atol=1e-13 * scale)
                gap = np.min(np.diff(w_ref)) / scale
                if gap > 1e-6:                       # eigenvectors are defined up to sign where distinct
                    signs = np.sign(np.sum(V * V_ref, axis=0))
                    np.testing.assert_allclose(V * signs, V_ref, rtol=0, atol=1e-13 / gap)


def test_solve_and_condition_equal_dposv_and_dpocon():
    rng = np.random.default_rng(42)
    for n, m in ((9, 0), (3, 20), (3, 0)):
        for spread in (0.0, 1.0, 2.5):
            for _ in range(50):
                A = _spd(rng, n, spread)
                B = rng.normal(size=(n, m) if m else n)
                chol, X_ref, info = lapack.dposv(A, B)
                assert info == 0
                rcond_ref = lapack.dpocon(chol, np.trace(A))[0]
                cond = 1.0 / rcond_ref
                np.testing.assert_allclose(small_lapack.solve(A, B), X_ref, rtol=1e-14 * cond,
                                           atol=1e-14 * cond * np.abs(X_ref).max())
                if B.ndim == 1:
                    x, rcond = small_lapack.solve_with_condition(A, B, np.trace(A))
                    np.testing.assert_allclose(x, X_ref, rtol=1e-14 * cond, atol=1e-14 * cond * np.abs(X_ref).max())
                else:
                    rcond = small_lapack.solve_with_condition(A, B[:, 0], np.trace(A))[1]
                assert rcond_ref / 3.0 <= rcond <= rcond_ref * 1.0001    # dpocon estimates ||A^-1||_1 from below


def test_singular_and_failed_give_nan_or_zero_without_warnings(recwarn):
    S = np.ones((9, 9))
    assert small_lapack.solve_with_condition(np.zeros((9, 9)), np.ones(9), 1.0)[1] == 0.0
    assert small_lapack.solve_with_condition(S, np.ones(9), 9.0)[1] < 1e-13
    assert not recwarn.list
    with np.errstate(invalid="ignore", divide="ignore"):
        assert not np.isfinite(small_lapack.solve(np.zeros((3, 3)), np.ones(3))).all()
