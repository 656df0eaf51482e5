"""Gyro B (eq. 41) and H (UKF eqs. 44-45; trust region eq. 43) on simulated tumble-table moves."""

import numpy as np
import pytest

from gyro_synth import rel_err, rng  # noqa: F401  (fixture)
from procedures.paper_table2 import random_gyro_truth, simulate_gyro_moves
from rig.calibration.turntable.gyro import calibrate_gyro_ukf, gyro_bias
from rig.calibration.turntable.gyro_baselines import calibrate_gyro_trust_region
from rig.session_data import MoveStream


def test_bias_is_the_sample_weighted_mean_of_the_holds(rng):
    holds = [rng.normal(rng.uniform(-30, 30, 3), 2.0, (n, 3)) for n in rng.integers(5, 400, 7)]
    B = gyro_bias(np.array([h.mean(axis=0) for h in holds]), np.array([len(h) for h in holds]))
    assert np.allclose(B, np.vstack(holds).mean(axis=0), rtol=0, atol=1e-9)


def test_bias_from_noisy_holds_is_within_its_standard_error(rng):
    H, B = random_gyro_truth(rng)
    noise = 0.01
    moves, hold_means = simulate_gyro_moves(rng, H, B, orientations=12, noise_rad_s=noise)
    est = gyro_bias(hold_means)
    counts_noise = noise / np.abs(np.diag(H)).min()  # per-sample noise in counts (bound)
    n = 12 * 90                                       # >= 90 samples per 1 s hold
    assert np.all(np.abs(est - B) < 5 * counts_noise / np.sqrt(n))


def test_bias_rejects_bad_input():
    with pytest.raises(ValueError, match="no stationary holds"):
        gyro_bias(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="counts"):
        gyro_bias(np.zeros((2, 3)), np.array([1.0, -1.0]))


@pytest.mark.parametrize("data_start", [False, True])
def test_ukf_recovers_h_from_clean_moves(rng, data_start):
    H, B = random_gyro_truth(rng)
    moves, _ = simulate_gyro_moves(rng, H, B, orientations=20)
    H0 = None if data_start else np.eye(3) / 939.65
    cal = calibrate_gyro_ukf(moves, B, H0=H0)
    assert rel_err(cal.H, H) <= 5e-4
    assert np.linalg.det(cal.H) > 0 and cal.converged and not cal.warnings
    assert cal.residual_rms < 1e-3                      # rad per move
    assert cal.H_std.shape == (3, 3) and np.all(np.isfinite(cal.H_std))


def test_trust_region_recovers_h_from_clean_moves(rng):
    H, B = random_gyro_truth(rng)
    moves, _ = simulate_gyro_moves(rng, H, B, orientations=20)
    cal = calibrate_gyro_trust_region(moves, B)
    assert rel_err(cal.H, H) <= 5e-4
    assert np.linalg.det(cal.H) > 0 and cal.converged


def test_noisy_moves_error_matches_reported_uncertainty(rng):
    H, B = random_gyro_truth(rng)
    moves, _ = simulate_gyro_moves(rng, H, B, orientations=20, noise_rad_s=0.005)
    ukf = calibrate_gyro_ukf(moves, B)
    trf = calibrate_gyro_trust_region(moves, B)
    sigma = np.sqrt(np.sum(ukf.H_std ** 2))
    assert rel_err(ukf.H, H) <= 1.5e-3
    assert np.linalg.norm(ukf.H - H) < 3 * sigma
    assert np.linalg.norm(ukf.H - trf.H) < 1.5 * sigma
    assert np.linalg.det(ukf.H) > 0


def test_ukf_error_decreases_over_passes(rng):
    H, B = random_gyro_truth(rng)
    moves, _ = simulate_gyro_moves(rng, H, B, orientations=20)
    history = []
    calibrate_gyro_ukf(moves, B, H0=np.eye(3) / 939.65, max_passes=4, tol=0.0, history=history)
    errors = [rel_err(h, H) for h in history]
    assert len(errors) == 4 and errors[-1] < errors[0] and errors[-1] <= 5e-4


def test_bad_move_is_named(rng):
    H, B = random_gyro_truth(rng)
    moves, _ = simulate_gyro_moves(rng, H, B, orientations=5)
    y = moves[2].y.copy()
    y[3, 1] = np.nan
    moves[2] = MoveStream(moves[2].step, moves[2].t, y, moves[2].R_start, moves[2].R_end)
    with pytest.raises(ValueError, match=f"move after hold {moves[2].step}"):
        calibrate_gyro_ukf(moves, B)
    with pytest.raises(ValueError, match="no moves"):
        calibrate_gyro_trust_region([], B)


def test_mirrored_axis_is_flagged_not_silently_fitted(rng):
    H, B = random_gyro_truth(rng)
    moves, _ = simulate_gyro_moves(rng, H @ np.diag([1.0, 1.0, -1.0]), B, orientations=12)
    for cal in (calibrate_gyro_ukf(moves, B, max_passes=5), calibrate_gyro_trust_region(moves, B)):
        assert any("does not explain the moves" in w for w in cal.warnings)


def _filterpy_move_update(x, P, Q, one, s, r_var, fit_points):
    """The fit's predict and update of one move through filterpy's UnscentedKalmanFilter, the reference."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    from rig.calibration.turntable.gyro import rotation_residuals

    points = MerweScaledSigmaPoints(9, alpha=fit_points.alpha, beta=fit_points.beta, kappa=fit_points.kappa)
    ukf = UnscentedKalmanFilter(dim_x=9, dim_z=3, dt=1.0, fx=lambda x, dt: x, hx=None, points=points)
    ukf.x, ukf.P, ukf.Q = x.copy(), P + Q, Q
    ukf.compute_process_sigmas(1.0)
    rows = iter(rotation_residuals(ukf.sigmas_f.reshape(-1, 3, 3) * s, one)[:, 0, :])
    ukf.update(np.zeros(3), R=np.eye(3) * r_var, hx=lambda _x: next(rows))
    assert next(rows, None) is None
    return ukf.x, 0.5 * (ukf.P + ukf.P.T)


@pytest.mark.parametrize("noise", [0.0, 0.005])
def test_fit_equals_filterpys_unscented_filter(rng, monkeypatch, noise):
    """The fit's batched update (filterpy's sigma points and unscented transform, the gain written out) gives
    filterpy's UnscentedKalmanFilter's result, pass by pass, to round-off."""
    import rig.calibration.turntable.gyro as gyro

    for _ in range(3):
        H, B = random_gyro_truth(rng)
        moves, _ = simulate_gyro_moves(rng, H, B, orientations=12, noise_rad_s=noise)
        ours_history, ref_history = [], []
        ours = calibrate_gyro_ukf(moves, B, history=ours_history)
        with monkeypatch.context() as m:
            m.setattr(gyro, "_ukf_move_update", _filterpy_move_update)
            ref = calibrate_gyro_ukf(moves, B, history=ref_history)
        assert ours.iterations == ref.iterations and len(ours_history) == len(ref_history)
        for a, b in zip(ours_history, ref_history):
            assert rel_err(a, b) < 1e-12
        np.testing.assert_allclose(ours.H_cov, ref.H_cov, rtol=1e-9, atol=1e-9 * np.abs(ref.H_cov).max())
