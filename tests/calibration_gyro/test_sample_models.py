"""What a gyro sample means (a rate at its stamp, or a mean over its period) and the integrator for each."""

import numpy as np
import pytest

from gyro_synth import rel_err, rng  # noqa: F401  (fixture)
from rig.calibration.turntable.gyro import calibrate_gyro
from rig.calibration.numerics.integrate import interval_terms, product_of_exps
from rig.rotations import matrix_from_quat, rot_x, rot_z
from rig.session_data import MoveStream


def _closed_form(t):
    """R(t) = Rz(a t) Rx(b t): body rate (b, a sin bt, a cos bt), a turning rate axis."""
    a, b = 1.3, 0.8
    return np.column_stack([np.full_like(t, b), a * np.sin(b * t), a * np.cos(b * t)]), rot_z(a * t[-1]) @ rot_x(b * t[-1])


def _window_means(rate, t, h, nodes=16):
    """The mean of rate(.) over (t_k - h, t_k], by Gauss-Legendre."""
    x, wts = np.polynomial.legendre.leggauss(nodes)
    tt = t[:, None] - h * (1 - x[None, :]) / 2
    return np.einsum("nkc,k->nc", rate(tt.ravel()).reshape(len(t), nodes, 3), wts / 2)


def _integrated(t, w, samples):
    S, C = interval_terms(t, w, samples)
    return matrix_from_quat(product_of_exps(S + C))


def test_point_samples_converge_at_fourth_order():
    errors = []
    for h in (0.02, 0.01, 0.005):
        t = np.arange(0.0, 2.0 + h / 2, h)
        w, R_true = _closed_form(t)
        errors.append(np.abs(_integrated(t, w, "point") - R_true).max())
    assert errors[0] / errors[1] > 12 and errors[1] / errors[2] > 12
    assert errors[0] < 1e-6


def test_mean_samples_need_the_mean_reading():
    """Window means read as point rates are wrong at second order; read as means they are near exact."""
    h, T = 0.02, 2.0
    t = np.arange(0.0, T + h / 2, h)
    rate = lambda s: np.column_stack([np.full_like(s, 0.8), 1.3 * np.sin(0.8 * s), 1.3 * np.cos(0.8 * s)])
    w = _window_means(rate, t, h)
    _, R_true = _closed_form(t)
    R0 = rot_z(1.3 * (-h)) @ rot_x(0.8 * (-h))      # the first window starts at t0 - h
    R_true = R0.T @ R_true
    as_mean = np.abs(_integrated(np.r_[t[0] - h, t], np.vstack([w[:1], w]), "mean") - R_true).max()
    as_point = np.abs(_integrated(t, w, "point") - _closed_form(t)[1]).max()
    assert as_mean < 1e-5 < 1e-4 < as_point


def _moves(sample_model: str, rate_hz: float, rng: np.random.Generator, H: np.ndarray, B: np.ndarray,
           noise_counts: float = 0.0, step_rad: float = 3.0):
    """Two-axis table moves (cosine velocity, both axes at once) sampled as point rates or window means."""
    K = np.linalg.inv(H)
    angles = np.cumsum(rng.uniform(-step_rad, step_rad, (13, 2)), axis=0)
    moves = []
    for j in range(12):
        (a0, b0), (a1, b1) = angles[j], angles[j + 1]
        T = 1.0 + rng.uniform(0, 0.5)

        def state(s):
            x = np.clip(s / T, 0, 1)
            shape, speed = x - np.sin(2 * np.pi * x) / (2 * np.pi), (1 - np.cos(2 * np.pi * x)) / T
            return a0 + (a1 - a0) * shape, (a1 - a0) * speed, b0 + (b1 - b0) * shape, (b1 - b0) * speed

        def rate(s):
            _, ad, b, bd = state(s)
            return np.column_stack([np.cos(b) * ad, -np.sin(b) * ad, bd])

        t = np.arange(-0.1, T + 0.1, 1.0 / rate_hz) + rng.uniform(0, 1.0 / rate_hz)
        w = rate(t) if sample_model == "point" else _window_means(rate, t, 1.0 / rate_hz)
        y = w @ K.T + B + noise_counts * rng.standard_normal((len(t), 3))
        moves.append(MoveStream(j, t, y, rot_x(a0) @ rot_z(b0), rot_x(a1) @ rot_z(b1)))
    return moves


@pytest.mark.parametrize("model", ["point", "mean"])
def test_auto_finds_the_sample_model_and_its_accuracy(rng, model):
    """Fast moves at 50 Hz (up to ~7 deg per sample): the wrong reading costs several times the error in H."""
    H = np.diag([1.02, 0.98, 1.01]) @ rot_z(0.01) @ rot_x(-0.02) * 1e-3
    B = np.array([12.0, -30.0, 7.0])
    moves = _moves(model, 50.0, rng, H, B)
    auto = calibrate_gyro(moves, B)
    other = calibrate_gyro(moves, B, samples="mean" if model == "point" else "point")
    assert auto.extra["sample_model"] == model
    assert rel_err(auto.H, H) < 5e-5
    assert rel_err(other.H, H) > 3 * rel_err(auto.H, H)


@pytest.mark.parametrize("samples", ["point", "mean"])
def test_streams_in_one_call_match_one_call_each(rng, samples):
    """Concatenated streams (one of them too short for a cubic) give each stream's own intervals, none across."""
    sizes = [7, 2, 3, 12, 4]
    ts = [np.cumsum(rng.uniform(0.005, 0.015, n)) + 10 * i for i, n in enumerate(sizes)]
    us = [rng.normal(0, 50, (n, 3)) for n in sizes]
    S, C = interval_terms(np.concatenate(ts), np.vstack(us), samples, np.array(sizes))
    one = [interval_terms(t, u, samples) for t, u in zip(ts, us)]
    assert S.shape == (sum(sizes) - len(sizes), 3)
    np.testing.assert_allclose(S, np.vstack([s for s, _ in one]), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(C, np.vstack([c for _, c in one]), rtol=1e-12, atol=1e-12)
    if samples == "point":
        h = np.diff(ts[1])[0]
        np.testing.assert_allclose(one[1][0][0], 0.5 * h * (us[1][0] + us[1][1]))   # two samples: the trapezoid


def test_auto_fits_one_reading_when_the_noise_explains_the_misfit(rng):
    """Slow moves at 100 Hz with 2 counts of noise: the readings cannot be told apart, so one fit is enough;
    fast mean-sampled moves at 50 Hz with 0.1 counts misfit far beyond their noise, and the mean reading wins."""
    H = np.diag([1.02, 0.98, 1.01]) @ rot_z(0.01) @ rot_x(-0.02) * 1e-3
    B = np.array([12.0, -30.0, 7.0])
    slow = calibrate_gyro(_moves("mean", 100.0, rng, H, B, noise_counts=2.0, step_rad=1.0), B,
                          rate_noise_counts=np.full(3, 2.0))
    assert slow.extra["point_misfit_to_noise"] < 1.5 and list(slow.extra["misfit_rad_by_sample_model"]) == ["point"]
    fast = calibrate_gyro(_moves("mean", 50.0, rng, H, B, noise_counts=0.1), B, rate_noise_counts=np.full(3, 0.1))
    assert fast.extra["point_misfit_to_noise"] > 3
    assert fast.extra["sample_model"] == "mean" and set(fast.extra["misfit_rad_by_sample_model"]) == {"point", "mean"}


def test_a_hole_in_the_samples_as_a_move_begins_is_integrated_with_a_linear_rate():
    """A retried table request stalls the reads for 0.05 s just as the table starts to turn: the cubic through
    the samples around that hole swung through it by milliradians (a fault campaign session, gyro H 2.5x its
    twin's error); the linear rate there is within the kink's own error."""
    alpha, h, start = 6.0, 0.01, 0.4355              # rad/s^2, s, s (between two sample stamps)
    t = np.round(np.arange(0.0, 1.0 + h / 2, h), 9)
    t = t[(t <= 0.38) | (t >= 0.43)]                 # the 0.05 s hole just before the table turns
    w = np.zeros((len(t), 3))
    w[:, 2] = alpha * np.clip(t - start, 0.0, None)
    R = _integrated(t, w, "point")
    exact = 0.5 * alpha * (t[-1] - start) ** 2
    assert abs(np.arctan2(R[1, 0], R[0, 0]) - exact) < 0.25 * alpha * h * h    # the cubic: 0.7 alpha h^2
