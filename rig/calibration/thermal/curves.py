"""A group of terms (B's 3 elements, or H's 9 in row-major order) as polynomials in temperature, fitted together.

One step's terms come with one covariance (B_cov 3x3, H_cov 9x9 from the step's calibration), so the group is a
seemingly-unrelated regression: each term has its own order, and all share the steps' full covariance:

    N = sum_k A_k' C_k^-1 A_k,   theta = N^-1 sum_k A_k' C_k^-1 z_k,   cov(theta) = N^-1,

A_k the block row of step k (term i's row `design(T_k - T_ref, p_i)` in term i's columns). A step's die
temperature is known only to its spread sigma_T, which moves each term by its slope: the effective-variance
method (Orear 1982) adds sigma_T^2 g_k g_k' to C_k, g_k the slopes of a first fit at T_k, and fits again.
The covariance is scaled by the reduced chi-square where that exceeds 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.thermal.polynomial import choose_order, derivative_design, design


@dataclass
class TermCurves:
    """Each term's polynomial in (T - reference): `orders[i]`, `coefficients[i]` (constant first), and the
    covariance of all coefficients concatenated in term order."""

    orders: list[int]
    coefficients: list[np.ndarray]
    covariance: np.ndarray
    order_scores: list[list[float]] = field(default_factory=list)   # held-out score per order, per term
    reduced_chi2: float = float("nan")

    @property
    def size(self) -> int:
        return len(self.orders)

    def jacobian(self, dt: float) -> np.ndarray:
        """d(terms)/d(theta) at one temperature offset: (terms, coefficients)."""
        J = np.zeros((self.size, self.covariance.shape[0]))
        col = 0
        for i, p in enumerate(self.orders):
            J[i, col:col + p + 1] = design(dt, p)[0]
            col += p + 1
        return J

    def values(self, dt: np.ndarray) -> np.ndarray:
        """The terms at each temperature offset: (n, terms)."""
        dt = np.atleast_1d(np.asarray(dt, dtype=float))
        return np.stack([design(dt, p) @ c for p, c in zip(self.orders, self.coefficients)], axis=1)

    def slopes(self, dt: np.ndarray) -> np.ndarray:
        dt = np.atleast_1d(np.asarray(dt, dtype=float))
        return np.stack([derivative_design(dt, p) @ c for p, c in zip(self.orders, self.coefficients)], axis=1)

    def covariance_at(self, dt: float) -> np.ndarray:
        J = self.jacobian(dt)
        return J @ self.covariance @ J.T


def step_covariance(cov: np.ndarray | None, std: np.ndarray | None, size: int, what: str) -> np.ndarray:
    """A step's covariance of its terms: the full one where given, else the diagonal of its deviations."""
    if cov is not None:
        C = np.asarray(cov, dtype=float).reshape(size, size)
    elif std is not None:
        C = np.diag(np.asarray(std, dtype=float).reshape(size) ** 2)
    else:
        raise ValueError(f"{what}: the step's calibration has no deviations; a temperature model weights each "
                         "step by them")
    C = 0.5 * (C + C.T)
    floor = 1e-12 * max(float(np.max(np.diag(C))), np.finfo(float).tiny)
    return C + floor * np.eye(size)


def fit_terms(dt: np.ndarray, Z: np.ndarray, C: np.ndarray, temp_std: np.ndarray,
              orders: list[int] | None = None, groups: list[list[int]] | None = None) -> TermCurves:
    """Fit a group of terms: Z (steps, terms), C (steps, terms, terms), temperature deviations (steps,).
    `orders`: fixed orders (a model told the true ones); None: each term's order chosen by held-out
    temperatures from its own variances (polynomial.choose_order)."""
    n, m = Z.shape
    scores: list[list[float]] = []
    if orders is None:
        var = np.einsum("kii->ki", C) + temp_std[:, None] ** 2 * _first_slopes(dt, Z) ** 2
        orders, scores = [0] * m, [[] for _ in range(m)]
        for group in groups or [[i] for i in range(m)]:
            choice = choose_order(dt, Z[:, group], var[:, group])
            for i in group:
                orders[i], scores[i] = choice.order, choice.scores
    curves = _solve(dt, Z, C, orders)
    if np.any(temp_std > 0):
        g = curves.slopes(dt)
        C = C + temp_std[:, None, None] ** 2 * np.einsum("ki,kj->kij", g, g)
        curves = _solve(dt, Z, C, orders)
    curves.order_scores = scores
    return curves


def _first_slopes(dt: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """Each term's slope at each step from neighbouring steps (for the order test's effective variances)."""
    order = np.argsort(dt)
    slopes = np.zeros_like(Z)
    if len(dt) > 1:
        slopes[order] = np.gradient(Z[order], dt[order], axis=0)
    return slopes


def _solve(dt: np.ndarray, Z: np.ndarray, C: np.ndarray, orders: list[int]) -> TermCurves:
    n, m = Z.shape
    sizes = [p + 1 for p in orders]
    q = sum(sizes)
    N = np.zeros((q, q))
    rhs = np.zeros(q)
    blocks = []
    for k in range(n):
        A = np.zeros((m, q))
        col = 0
        for i, p in enumerate(orders):
            A[i, col:col + p + 1] = design(dt[k], p)[0]
            col += p + 1
        Ci = np.linalg.inv(C[k])
        N += A.T @ Ci @ A
        rhs += A.T @ Ci @ Z[k]
        blocks.append((A, Ci))
    cov = np.linalg.inv(N)
    theta = cov @ rhs
    chi2 = sum(float((Z[k] - A @ theta) @ Ci @ (Z[k] - A @ theta)) for k, (A, Ci) in enumerate(blocks))
    dof = n * m - q
    reduced = chi2 / dof if dof > 0 else float("nan")
    if dof > 0 and reduced > 1.0:
        cov = cov * reduced
    coefficients = np.split(theta, np.cumsum(sizes)[:-1])
    return TermCurves(orders=list(orders), coefficients=[np.asarray(c) for c in coefficients],
                      covariance=0.5 * (cov + cov.T), reduced_chi2=reduced)
