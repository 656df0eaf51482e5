"""Polynomials in temperature and the choice of their order by held-out temperatures.

Each term (one element of B or of H) is `z(T) = sum_j c_j (T - T_ref)^j`, fitted here one term at a time by
weighted least squares over the steps' stated variances (theta = (A' W A)^-1 A' W z, cov = (A' W A)^-1); the
final fit of a group of terms over the steps' full covariances is curves.py's.

Order: leave-one-temperature-out. Each interior step (never the coldest or the hottest: the model is never used
outside the steps' range, so the test is interpolation, as its use is) is held out in turn, the term is fitted
to the others at order p, and the held-out value predicted; its standardised predictive error is
`r^2 = (z_k - z_hat_k)^2 / (var z_k + var z_hat_k)`, whose mean over the held-out steps is the order's score
(about 1 for every order that can follow the curve, more for one that cannot: a curve left out shows as misfit
in units of what the prediction says it can know) and whose standard error is the scatter of the r^2 over
sqrt(n). A group of terms that share one order (H's three scales) pools its r^2. Parsimony: the lowest order
whose score, less its own standard error, is no worse than the best score.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_ORDER = 3


def design(dt: np.ndarray, order: int) -> np.ndarray:
    """Rows [1, dt, dt^2, ..., dt^order] for temperatures relative to the reference."""
    return np.vander(np.atleast_1d(np.asarray(dt, dtype=float)), order + 1, increasing=True)


def derivative_design(dt: np.ndarray, order: int) -> np.ndarray:
    """Rows d/dT of `design`: [0, 1, 2 dt, 3 dt^2, ...]."""
    dt = np.atleast_1d(np.asarray(dt, dtype=float))
    out = np.zeros((dt.size, order + 1))
    for j in range(1, order + 1):
        out[:, j] = j * dt ** (j - 1)
    return out


def wls(dt: np.ndarray, z: np.ndarray, var: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least squares of one term at one order: coefficients and their covariance (not chi-square
    scaled: the stated variances are taken as they are, which the order test needs)."""
    A = design(dt, order)
    w = 1.0 / var
    N = A.T @ (A * w[:, None])
    cov = np.linalg.inv(N)
    return cov @ (A.T @ (w * z)), cov


@dataclass
class OrderChoice:
    order: int
    scores: list[float]          # mean standardised held-out r^2 per order 0..max
    score_se: list[float]        # its standard error


def max_order(n_steps: int) -> int:
    """The highest order a held-out fit can test with one degree of freedom to spare: each held-out fit has
    n - 1 steps, so p + 2 <= n - 1."""
    return int(min(MAX_ORDER, n_steps - 3))


def choose_order(dt: np.ndarray, z: np.ndarray, var: np.ndarray, highest: int | None = None) -> OrderChoice:
    """The order of one term (z, var: (steps,)) or of a group of terms sharing one order (z, var: (steps, terms),
    their held-out errors pooled) by leave-one-interior-temperature-out (module docstring). With 3 steps or
    fewer no held-out test is possible: the straight line through them (1 step: the constant)."""
    z = np.asarray(z, dtype=float).reshape(len(dt), -1)
    var = np.asarray(var, dtype=float).reshape(len(dt), -1)
    n = len(dt)
    top = max_order(n) if highest is None else min(highest, max_order(n))
    if n <= 3:
        return OrderChoice(order=min(1, n - 1), scores=[], score_se=[])
    interior = np.argsort(dt)[1:-1]
    scores, ses = [], []
    for p in range(top + 1):
        r2 = []
        for k in interior:
            keep = np.arange(n) != k
            a = design(dt[k], p)[0]
            for i in range(z.shape[1]):
                theta, cov = wls(dt[keep], z[keep, i], var[keep, i], p)
                r2.append((z[k, i] - a @ theta) ** 2 / (var[k, i] + a @ cov @ a))
        r2 = np.asarray(r2)
        scores.append(float(np.mean(r2)))
        ses.append(float(np.std(r2, ddof=1) / np.sqrt(r2.size)) if r2.size > 1 else float("inf"))
    best = float(np.min(scores))
    chosen = next(p for p in range(top + 1) if scores[p] - ses[p] <= best)
    return OrderChoice(order=chosen, scores=scores, score_se=ses)
