"""The joint estimator's Levenberg-Marquardt (levenberg.py) against scipy's least_squares(method="lm"),
the MINPACK reference it replaces on the start-up path and keeps as its fallback."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

import rig.calibration.joint as joint
import rig.calibration.levenberg as levenberg
from rig.calibration.levenberg import LMResult, levenberg_marquardt
from vector_synth import accel_truth, mag_truth, random_rotations


def _scipy_lm(residuals, jacobian, p0):
    return least_squares(residuals, p0, jac=jacobian, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)


def _rel(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))


def _problems(rng: np.random.Generator):
    """(y, R, norm, y_std, counts): accel and mag truths, 6 to 30 holds, clean to noisy, some near-degenerate
    (holds bunched in a cone, so the matrix is barely observable) and one hold far off its noise."""
    for i in range(40):
        truth = (accel_truth if i % 2 else mag_truth)(rng)
        n = int(rng.integers(6, 31))
        R = random_rotations(n, rng)
        if i % 5 == 0:                                        # bunched: rotations within ~35 deg of one
            axis_angle = rng.normal(size=(n, 3)) * 0.35
            R = np.array([_rotvec_matrix(v) for v in axis_angle]) @ R[0]
        noise = [0.0, 1e-3, 0.05, 0.5][i % 4] * (1 if truth.norm > 20 else 3)
        y = truth.holds(R, noise, rng)
        if i % 7 == 3:
            y[0] += 20 * max(noise, 0.01)
        y_std = np.full((n, 3), max(noise, 1e-6) * np.sqrt(200))
        yield y, R, truth.norm, y_std, np.full(n, 200)


def _rotvec_matrix(v):
    from rig.rotations import matrix_from_rotvec
    return matrix_from_rotvec(v)


def test_joint_refinement_reaches_scipys_optimum(monkeypatch):
    rng = np.random.default_rng(51)
    compared = 0
    for y, R, norm, y_std, counts in _problems(rng):
        try:
            ours = joint.calibrate_joint(y, R, norm, y_std=y_std, counts=counts)
        except Exception as e:                          # the same refusal with scipy below
            with monkeypatch.context() as m, pytest.raises(type(e)):
                m.setattr(joint, "least_squares_lm", _scipy_lm)
                joint.calibrate_joint(y, R, norm, y_std=y_std, counts=counts)
            continue
        with monkeypatch.context() as m:
            m.setattr(joint, "least_squares_lm", _scipy_lm)
            ref = joint.calibrate_joint(y, R, norm, y_std=y_std, counts=counts)
        # The same optimum: where it is flat (holds bunched, noisy), two optimisers may stop anywhere within their
        # tolerance of it, so the bound is a small fraction of the estimate's own standard deviation.
        assert np.abs(ours.H - ref.H).max() < 1e-5 * ref.H_std.min()
        assert np.abs(ours.B - ref.B).max() < 1e-5 * ref.B_std.min()
        assert _rel(ours.H_cov, ref.H_cov) < 1e-6 and _rel(ours.B_cov, ref.B_cov) < 1e-6
        assert abs(ours.extra["reduced_chi2"] - ref.extra["reduced_chi2"]) <= 1e-8 * ref.extra["reduced_chi2"] + 1e-20
        assert ours.converged == ref.converged
        compared += 1
    assert compared >= 30


def test_generic_problems_match_scipy():
    """Curve fits started away from their optimum (an exponential decay with an offset, a Gaussian peak),
    and Rosenbrock's zero-residual valley."""
    rng = np.random.default_rng(52)
    t = np.linspace(0, 4, 40)
    for _ in range(20):
        a = rng.uniform(0.5, 2, 3)
        for model, grad in (
                (lambda p: p[0] * np.exp(-p[1] * t) + p[2],
                 lambda p: np.column_stack([np.exp(-p[1] * t), -t * p[0] * np.exp(-p[1] * t), np.ones_like(t)])),
                (lambda p: p[0] * np.exp(-((t - p[1]) / p[2]) ** 2),
                 lambda p: np.column_stack([np.exp(-((t - p[1]) / p[2]) ** 2),
                                            2 * p[0] * (t - p[1]) / p[2] ** 2 * np.exp(-((t - p[1]) / p[2]) ** 2),
                                            2 * p[0] * (t - p[1]) ** 2 / p[2] ** 3
                                            * np.exp(-((t - p[1]) / p[2]) ** 2)]))):
            data = model(a) + 1e-3 * rng.normal(size=t.size)
            f = lambda p, model=model, data=data: model(p) - data  # noqa: E731
            x0 = a * rng.uniform(0.8, 1.2, 3)
            ours = levenberg_marquardt(f, grad, x0)
            ref = least_squares(f, x0, jac=grad, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)
            assert ours.success and ref.success
            assert abs(ours.cost - ref.cost) <= 1e-12 * ref.cost
            # MINPACK's ftol = 1e-14 stops once a step would lower the sum by 1e-14 of itself, which places x
            # within ~1e-6 of its standard error of the optimum: compare on that scale
            J = grad(ref.x)
            cov = np.linalg.inv(J.T @ J) * 2 * ref.cost / (t.size - 3)
            dx = ours.x - ref.x
            assert dx @ np.linalg.solve(cov, dx) < 1e-10
    rosen = lambda p: np.array([10 * (p[1] - p[0] ** 2), 1 - p[0]])  # noqa: E731
    rosen_j = lambda p: np.array([[-20 * p[0], 10.0], [-1.0, 0.0]])  # noqa: E731
    sol = levenberg_marquardt(rosen, rosen_j, np.array([-1.2, 1.0]))
    assert sol.success and np.allclose(sol.x, [1.0, 1.0], rtol=0, atol=1e-12) and sol.cost < 1e-25


def test_falls_back_to_scipy_when_ours_does_not_converge(monkeypatch):
    rng = np.random.default_rng(53)
    y, R, norm, y_std, counts = next(_problems(rng))
    normal = joint.calibrate_joint(y, R, norm, y_std=y_std, counts=counts)
    calls = []

    def failing(fun, jac, x0, **_):
        calls.append(1)
        return LMResult(x0, fun(x0), jac(x0), 0.0, 1, 1, False, "stub")

    monkeypatch.setattr(levenberg, "levenberg_marquardt", failing)
    fallback = joint.calibrate_joint(y, R, norm, y_std=y_std, counts=counts)
    assert calls and fallback.converged
    assert _rel(fallback.H, normal.H) < 1e-10


def test_stops_on_max_evaluations_and_non_finite_starts():
    rosen = lambda p: np.array([10 * (p[1] - p[0] ** 2), 1 - p[0]])  # noqa: E731
    rosen_j = lambda p: np.array([[-20 * p[0], 10.0], [-1.0, 0.0]])  # noqa: E731
    sol = levenberg_marquardt(rosen, rosen_j, np.array([-1.2, 1.0]), max_nfev=3)
    assert not sol.success and "maximum number" in sol.message
    sol = levenberg_marquardt(lambda p: np.array([np.nan]), lambda p: np.ones((1, 1)), np.array([0.0]))
    assert not sol.success
