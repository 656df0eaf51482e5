"""integrate_rotation: the Int operator of eqs. 52-55 against closed forms and an ODE solver."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from gyro_synth import rng  # noqa: F401  (fixture)
from rig.calibration.numerics.integrate import integrate_quaternion, integrate_rotation, interval_rotvecs
from rig.rotations import rot_x, rot_z, skew


def test_constant_rate_is_exact(rng):
    w = rng.normal(0, 2.0, 3)
    t = np.sort(rng.uniform(0, 3, 257))
    R = integrate_rotation(t, np.tile(w, (t.size, 1)))
    assert np.abs(R - expm(skew(w) * (t[-1] - t[0]))).max() < 1e-12


def test_fixed_axis_piecewise_linear_rate_matches_trapezoid_angle(rng):
    axis = rng.normal(0, 1, 3)
    axis /= np.linalg.norm(axis)
    t = np.cumsum(rng.uniform(0.005, 0.015, 400))
    rate = np.cumsum(rng.normal(0, 0.3, t.size))
    angle = np.sum(0.5 * np.diff(t) * (rate[1:] + rate[:-1]))
    R = integrate_rotation(t, np.outer(rate, axis))
    assert np.abs(R - expm(skew(axis) * angle)).max() < 1e-11


def test_time_varying_axis_closed_form_converges_at_second_order():
    """R(t) = Rz(a t) Rx(b t) has body rate (b, a sin bt, a cos bt): a non-commuting closed form."""
    a, b, T = 1.3, 0.8, 2.0
    errors = []
    for h in (0.004, 0.002, 0.001):
        t = np.arange(0.0, T + h / 2, h)
        w = np.column_stack([np.full_like(t, b), a * np.sin(b * t), a * np.cos(b * t)])
        errors.append(np.abs(integrate_rotation(t, w) - rot_z(a * T) @ rot_x(b * T)).max())
    assert errors[-1] < 2e-7
    assert 3.5 < errors[0] / errors[1] < 4.5 and 3.5 < errors[1] / errors[2] < 4.5


def _ode_reference(t, w):
    """R' = R [w x] with w linear between samples, solved interval by interval (DOP853, tight)."""
    R = np.eye(3)
    for k in range(len(t) - 1):
        t0, t1, w0, w1 = t[k], t[k + 1], w[k], w[k + 1]
        f = lambda s, r: (r.reshape(3, 3) @ skew(w0 + (w1 - w0) * (s - t0) / (t1 - t0))).ravel()
        R = solve_ivp(f, (t0, t1), R.ravel(), method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1].reshape(3, 3)
    return R


def test_sample_accurate_for_linear_rate_segments(rng):
    """Table-like rates (up to ~2 rad/s, ~5 rad/s^2) at 100 Hz: a few 1e-9 from the exact solution."""
    t = np.arange(0.0, 1.0, 0.01)
    w = np.cumsum(rng.normal(0, 0.05, (t.size, 3)), axis=0) + rng.normal(0, 1.0, 3)
    err = np.abs(integrate_rotation(t, w) - _ode_reference(t, w)).max()
    assert err < 1e-8


def _subdivide(t, w, n):
    ts = np.concatenate([np.linspace(t[k], t[k + 1], n + 1)[:-1] for k in range(len(t) - 1)] + [t[-1:]])
    return ts, np.column_stack([np.interp(ts, t, w[:, i]) for i in range(3)])


def test_fourth_order_on_the_same_piecewise_linear_rate(rng):
    """Halving the step on the same linear-segment rate cuts the error 16x (Magnus order 4)."""
    t = np.arange(0.0, 1.0, 0.01)
    w = np.cumsum(rng.normal(0, 0.4, (t.size, 3)), axis=0) + rng.normal(0, 1.5, 3)
    ref = integrate_rotation(*_subdivide(t, w, 64))
    e1, e2 = (np.abs(integrate_rotation(*_subdivide(t, w, n)) - ref).max() for n in (2, 4))
    assert 12 < e1 / e2 < 20


def test_composition_over_split_interval(rng):
    t = np.cumsum(rng.uniform(0.008, 0.012, 300))
    w = rng.normal(0, 1.0, (t.size, 3))
    m = 137
    R_whole = integrate_rotation(t, w)
    R_split = integrate_rotation(t[:m + 1], w[:m + 1]) @ integrate_rotation(t[m:], w[m:])
    assert np.abs(R_whole - R_split).max() < 1e-13


def test_stacked_histories_match_one_by_one(rng):
    t = np.arange(0.0, 0.77, 0.01)
    w = rng.normal(0, 1.0, (4, t.size, 3))
    stacked = integrate_rotation(t, w)
    assert stacked.shape == (4, 3, 3)
    for k in range(4):
        assert np.abs(stacked[k] - integrate_rotation(t, w[k])).max() < 1e-14


def test_large_steps_take_the_exact_branch():
    t = np.array([0.0, 1.0])
    w = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 2.0]])
    assert np.abs(integrate_rotation(t, w) - rot_z(2.0)).max() < 1e-14


def test_single_sample_is_identity():
    q = integrate_quaternion(np.array([0.0]), np.zeros((1, 3)))
    assert np.allclose(q, [1, 0, 0, 0])


def test_bad_input_is_named():
    with pytest.raises(ValueError, match=r"t\[1\]"):
        integrate_rotation(np.array([0.0, 0.0, 0.1]), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="shape"):
        integrate_rotation(np.arange(4.0), np.zeros((3, 3)))


@pytest.mark.parametrize("n", [1, 2, 3, 5, 17, 1000, 1025, 2049])
def test_tree_product_matches_sequential_composition(rng, n):
    """Odd leftovers at every level of the pairwise product keep their place in time."""
    t = np.cumsum(rng.uniform(0.005, 0.015, n + 1))
    w = rng.normal(0, 1.0, (n + 1, 3))
    R = np.eye(3)
    for phi in interval_rotvecs(t, w):
        R = R @ Rotation.from_rotvec(phi).as_matrix()
    assert np.abs(integrate_rotation(t, w) - R).max() < 1e-13
    assert np.abs(integrate_rotation(t, np.stack([w] * 19))[7] - R).max() < 1e-13
