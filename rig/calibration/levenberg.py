"""Levenberg-Marquardt least squares with an analytic Jacobian, for the joint estimator's refinement.

What the joint estimator asked of scipy's `least_squares(method="lm")` (MINPACK's lmder), in numpy: importing
scipy.optimize costs ~0.25 s, more than half of what a whole `rig calibrate --from` may take (issue 17,
start-up). The joint estimator still falls back to scipy's when this one does not converge, and
tests/calibration_vector/test_levenberg.py holds both to the same optimum on many random problems,
ill-conditioned ones included.

Each Jacobian is scaled by its column norms, kept at their largest so far (Moré 1978, as MINPACK), and
factored once by an SVD, which gives the step for any damping without a new factorisation:
`y = -V diag(s / (s^2 + lambda)) U^T r`. The damping follows Nielsen's rule (Madsen, Nielsen & Tingleff,
"Methods for non-linear least squares problems", 2004, eq. 3.15) from `1e-8 s_max^2`: the joint fit starts
next to its optimum, where Gauss-Newton steps are the fast ones. Stops as MINPACK does: on the gradient
(gtol), on the relative reduction of the sum of squares, actual and predicted (ftol; or the Gauss-Newton
step's predicted alone, which bounds every step's), or on the relative size of the scaled step (xtol).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

START_DAMPING = 1e-8
ACCEPT_RATIO = 1e-4        # of actual to predicted reduction, below which a step is retried with more damping


@dataclass
class LMResult:
    x: np.ndarray
    fun: np.ndarray        # residuals at x
    jac: np.ndarray        # Jacobian at x
    cost: float            # half the sum of squares, as scipy reports it
    nfev: int
    njev: int
    success: bool
    message: str


def levenberg_marquardt(fun: Callable[[np.ndarray], np.ndarray], jac: Callable[[np.ndarray], np.ndarray],
                        x0: np.ndarray, *, xtol: float = 1e-14, ftol: float = 1e-14, gtol: float = 1e-14,
                        max_nfev: int | None = None) -> LMResult:
    """Minimise |fun(x)|^2 from x0; `jac(x)` is d fun / d x, (m, n)."""
    x = np.array(x0, dtype=float)
    max_nfev = 100 * (x.size + 1) if max_nfev is None else max_nfev
    r, J = np.asarray(fun(x), dtype=float), np.asarray(jac(x), dtype=float)
    nfev = njev = 1
    sse = float(r @ r)
    if not (math.isfinite(sse) and np.isfinite(J).all()):
        return LMResult(x, r, J, 0.5 * sse, nfev, njev, False, "residuals or Jacobian not finite at the start")
    d = _column_norms(J)
    lam, nu = None, 2.0
    while True:
        Js = J / d
        if sse == 0.0 or np.max(np.abs(Js.T @ r)) <= gtol * math.sqrt(sse):
            return LMResult(x, r, J, 0.5 * sse, nfev, njev, True, "`gtol` termination condition is satisfied.")
        U, s, Vt = np.linalg.svd(Js, full_matrices=False)
        Ur = U.T @ r
        if float(Ur @ Ur) <= ftol * sse:      # even the Gauss-Newton step would lower the sum by less than ftol
            return LMResult(x, r, J, 0.5 * sse, nfev, njev, True, "`ftol` termination condition is satisfied.")
        lam = START_DAMPING * float(s[0]) ** 2 if lam is None else lam
        while True:
            if nfev >= max_nfev:
                return LMResult(x, r, J, 0.5 * sse, nfev, njev, False,
                                "The maximum number of function evaluations is exceeded.")
            dx = (Vt.T @ (-(s / (s * s + lam)) * Ur)) / d
            x_new = x + dx
            r_new = np.asarray(fun(x_new), dtype=float)
            nfev += 1
            sse_new = float(r_new @ r_new)
            r_lin = r + J @ dx
            predicted = sse - float(r_lin @ r_lin)
            actual = sse - sse_new if math.isfinite(sse_new) else -math.inf
            small_step = math.sqrt(float(np.sum((d * dx) ** 2))) <= xtol * math.sqrt(float(np.sum((d * x) ** 2)))
            rho = actual / predicted if predicted > 0 else -1.0
            reduced = abs(actual) <= ftol * sse and 0.0 <= predicted <= ftol * sse and rho <= 2.0
            accepted = rho >= ACCEPT_RATIO
            if accepted:
                x, r, sse = x_new, r_new, sse_new
                J = np.asarray(jac(x), dtype=float)
                njev += 1
                if not np.isfinite(J).all():
                    return LMResult(x, r, J, 0.5 * sse, nfev, njev, False, "Jacobian not finite")
                d = np.maximum(d, _column_norms(J))
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
            else:
                lam *= nu
                nu *= 2.0
            if reduced or small_step:     # tested on every trial, as MINPACK: the last ones may not reduce the sum
                which = "`ftol`" if reduced else "`xtol`"
                return LMResult(x, r, J, 0.5 * sse, nfev, njev, True, f"{which} termination condition is satisfied.")
            if accepted:
                break


def _column_norms(J: np.ndarray) -> np.ndarray:
    norms = np.sqrt(np.einsum("ij,ij->j", J, J))
    return np.where(norms > 0, norms, 1.0)


def minimise(fun: Callable[[np.ndarray], np.ndarray], jac: Callable[[np.ndarray], np.ndarray] | None,
             x0: np.ndarray, *, tol: float = 1e-14, max_nfev: int | None = None):
    """Least squares by ours, else scipy's MINPACK from the same start (imported only on that rarely taken path:
    scipy.optimize costs ~0.25 s to import). `jac` None: forward differences. The result has x, fun, jac,
    success and nfev, whichever minimiser gave it."""
    jac = jac or forward_difference(fun)
    sol = levenberg_marquardt(fun, jac, x0, xtol=tol, ftol=tol, gtol=tol, max_nfev=max_nfev)
    if sol.success:
        return sol
    from scipy.optimize import least_squares

    return least_squares(fun, x0, jac=jac, method="lm", xtol=tol, ftol=tol, gtol=tol,
                         max_nfev=max_nfev or 100 * (len(x0) + 1))


def forward_difference(fun: Callable[[np.ndarray], np.ndarray], rel_step: float = 1.5e-8):
    """d fun / d x by forward differences (MINPACK's step: sqrt(machine epsilon) times |x|, at least that)."""
    def jac(x: np.ndarray) -> np.ndarray:
        r0 = np.asarray(fun(x), dtype=float)
        J = np.empty((r0.size, x.size))
        for i in range(x.size):
            h = rel_step * max(abs(x[i]), 1.0)
            xi = x.copy()
            xi[i] += h
            J[:, i] = (np.asarray(fun(xi), dtype=float) - r0) / h
        return J
    return jac
