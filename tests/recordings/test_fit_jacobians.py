"""The recording fits' analytic Jacobians are the derivatives of what they fit: checked against central
differences at points away from the start."""

import numpy as np

import rig.calibration.recordings.recording_fits as recording_fits
from rig.calibration.numerics import mag_fit

UPS = ["+x", "-x", "+y", "-y", "+z", "-z", None, None, "+z", None]


def central_differences(fun, p, step=1e-6):
    return np.array([(fun(p + step * e) - fun(p - step * e)) / (2 * step) for e in np.eye(len(p))]).T


def test_the_face_fits_jacobian_is_the_derivative_of_its_residuals(monkeypatch):
    """Tilts not zero, one pose's standard error on its floor, poses known by their norm only."""
    rng = np.random.default_rng(1)
    means = np.array([9.8 * np.array(recording_fits.AXIS_VECTORS[u]) if u else 5.6 * rng.normal(size=3) for u in UPS])
    means += 0.3 * rng.normal(size=means.shape)
    se = 1e-3 + 0.01 * np.abs(rng.normal(size=means.shape))
    se[2] = 1e-9
    problem = {}
    solve = recording_fits.least_squares

    def spy(fun, p0, jac=None, **options):
        problem.update(fun=fun, jac=jac)
        return solve(fun, p0, jac=jac, **options)

    monkeypatch.setattr(recording_fits, "least_squares", spy)
    recording_fits.fit_faces(means, se, UPS, np.full(len(UPS), 0.02), 9.81)
    assert callable(problem["jac"])
    n_known = sum(u is not None for u in UPS)
    for _ in range(4):
        p = np.concatenate([0.3 * rng.normal(size=3), np.eye(3).ravel() + 0.05 * rng.normal(size=9),
                            0.05 * rng.normal(size=2 * n_known)])
        numeric = central_differences(problem["fun"], p)
        assert np.max(np.abs(problem["jac"](p) - numeric)) < 1e-6 * np.max(np.abs(numeric))


def test_the_magnetometer_rotations_jacobian_is_its_derivative_at_every_start():
    """Far from zero, below the series' threshold and at zero, for every start the alignment tries."""
    rng = np.random.default_rng(2)
    for P in mag_fit.signed_permutations():
        for x in (0.8 * rng.normal(size=3), 3e-5 * rng.normal(size=3), np.zeros(3)):
            numeric = central_differences(lambda v: (mag_fit._rotation(v) @ P).ravel(), x)
            assert np.max(np.abs(mag_fit._rotated_columns_jacobian(x, P) - numeric)) < 1e-7
