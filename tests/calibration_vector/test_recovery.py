"""Two-step (and joint) recovery of B and H from clean synthetic holds, 20 random orientations."""

import numpy as np
import pytest

from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.turntable.twostep import calibrate_two_step

from vector_synth import accel_truth, h_error, mag_truth, random_rotations

# Clean = hold means averaged over many samples: 0.02 counts left of the noise.
CLEAN_NOISE = 0.02


@pytest.mark.parametrize("make_truth", [accel_truth, mag_truth], ids=["accel", "mag"])
@pytest.mark.parametrize("solver", [calibrate_two_step, calibrate_joint], ids=["two-step", "joint"])
def test_recovers_B_and_H_with_det_positive(make_truth, solver, rng):
    for _ in range(5):
        truth = make_truth(rng)
        R = random_rotations(20, rng)
        cal = solver(truth.holds(R, CLEAN_NOISE, rng), R, truth.norm)
        assert h_error(cal.H, truth.H) <= 5e-4
        assert np.linalg.norm(cal.B - truth.B) < 1e-3 * np.linalg.norm(truth.B)
        assert np.linalg.det(cal.H) > 0
        assert cal.converged and not cal.warnings


def test_magnetometer_field_pointing_down_gets_reference_with_dip(rng):
    truth = mag_truth(rng)
    R = random_rotations(20, rng)
    cal = calibrate_two_step(truth.holds(R, 0.0, rng), R, truth.norm)
    v = np.asarray(cal.extra["reference_world"])
    np.testing.assert_allclose(v, truth.v, atol=1e-6 * truth.norm)
    assert np.degrees(np.arcsin(-v[2] / np.linalg.norm(v))) == pytest.approx(60.0, abs=1e-6)


def test_two_step_iteration_history_converges_monotonically_to_truth(rng):
    truth = accel_truth(rng)
    R = random_rotations(20, rng)
    cal = calibrate_two_step(truth.holds(R, 0.0, rng), R, truth.norm, record_history=True)
    errors = [h_error(H, truth.H) for H in cal.extra["history"]]
    assert len(errors) == cal.iterations
    assert errors[-1] < 1e-8 < errors[0]
    assert all(b <= a * 1.0001 for a, b in zip(errors[5:], errors[6:]))


def test_two_step_reports_nonconvergence(rng):
    truth = accel_truth(rng)
    R = random_rotations(20, rng)
    cal = calibrate_two_step(truth.holds(R, 0.5, rng), R, truth.norm, max_iter=2, tol=1e-15)
    assert not cal.converged
    assert any("did not converge" in w for w in cal.warnings)


def test_residual_is_vector_misfit_in_calibrated_units(rng):
    truth = accel_truth(rng)
    R = random_rotations(20, rng)
    noise_counts = 2.0
    cal = calibrate_two_step(truth.holds(R, noise_counts, rng), R, truth.norm)
    per_axis_mps2 = noise_counts / 400.0
    assert 0.3 * per_axis_mps2 < cal.residual_rms < 3 * np.sqrt(3) * per_axis_mps2
