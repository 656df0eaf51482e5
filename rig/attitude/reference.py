"""The same quaternion UKF run through filterpy's `UnscentedKalmanFilter`: slow, but written as the
textbook error-state UKF, so it checks the hand-unrolled kernel (the tests hold the two to agree).

filterpy carries the error rotation vector `d` (zero after every reset); the mean quaternion lives
outside it. Process: `d <- R(dq)^T d` with Q from the gyro noise (eq. 16). Measurement of the sigma
point `q Exp(d)` (see `ukf.py`): the gravity direction and the heading in one update ('heading' mode),
or the gravity direction, then the field direction in a second update ('vector' mode). filterpy's update reuses the
sigma points of the predict step, drawn before Q was added; they are redrawn from the predicted
covariance first, as the kernel does.
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from rig.attitude.measurements import field_in_navigation
from rig.attitude.ukf import (STATE_DIM, AttitudeEstimate, SensorNoise, UKFSettings, finish, setup_filter)
from rig.rotations import matrix_from_quat, quat_multiply
from rig.calibration.numerics.integrate import quat_exp


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _direction(R_mean: np.ndarray, d: np.ndarray, v_nav: np.ndarray) -> np.ndarray:
    return (R_mean @ matrix_from_quat(quat_exp(d))).T @ v_nav


def _measure(R_mean: np.ndarray, d: np.ndarray, up: np.ndarray, north: np.ndarray | None) -> np.ndarray:
    R = R_mean @ matrix_from_quat(quat_exp(d))
    g = R.T @ np.array([0.0, 0.0, 1.0])
    if north is None:
        return g
    p = R.T @ np.array([0.0, 1.0, 0.0])
    return np.append(g, math.atan2(np.cross(up, north) @ p, north @ p))


def _z_mean(sigmas: np.ndarray, Wm: np.ndarray) -> np.ndarray:
    z = Wm @ sigmas
    if sigmas.shape[1] == 4:
        z[3] = sigmas[0, 3] + Wm @ _wrap(sigmas[:, 3] - sigmas[0, 3])
    return z


def _residual_z(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    r = np.subtract(a, b)
    if r.shape[0] == 4:
        r[3] = _wrap(r[3])
    return r


UP = np.array([0.0, 0.0, 1.0])


def _update(ukf: UnscentedKalmanFilter, points: MerweScaledSigmaPoints, q: np.ndarray, z: np.ndarray, var,
            h) -> np.ndarray:
    """One filterpy update with sigma points redrawn around the prediction, then the reset q <- q Exp(d)."""
    ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
    R_mean = matrix_from_quat(q)
    ukf.update(np.asarray(z, dtype=float), R=np.diag(np.broadcast_to(var, (len(z),)).astype(float)),
               hx=lambda d: h(R_mean, d))
    q = quat_multiply(q, quat_exp(ukf.x))
    ukf.x = np.zeros(STATE_DIM)
    return q


def estimate_attitude_filterpy(t, gyro, accel, mag=None, *, gravity: float = 9.80665, field_uT: float | None = None,
                               noise: SensorNoise | None = None, still_rows=None,
                               settings: UKFSettings | None = None) -> AttitudeEstimate:
    settings = settings or UKFSettings()
    setup = setup_filter(t, gyro, accel, mag, gravity=gravity, field_uT=field_uT, noise=noise,
                         still_rows=still_rows, settings=settings)
    prep = setup.prep
    points = MerweScaledSigmaPoints(STATE_DIM, alpha=settings.alpha, beta=settings.beta, kappa=settings.kappa)
    ukf = UnscentedKalmanFilter(dim_x=STATE_DIM, dim_z=4, dt=1.0, hx=None, fx=None, points=points,
                                z_mean_fn=_z_mean, residual_z=_residual_z)
    ukf.x = np.zeros(STATE_DIM)
    ukf.P = setup.P0.copy()
    q = np.asarray(setup.q0, dtype=float)
    vector = settings.mag_measurement == "vector"
    field_nav = np.array(field_in_navigation(setup.dip_rad))
    quats, diag = [], []
    n_acc = n_mag = 0
    for k in range(len(setup.t)):
        A = np.array(prep.A[k]).reshape(3, 3)
        ukf.Q = prep.q_var[k] * np.eye(STATE_DIM)
        ukf.predict(fx=lambda d, dt: A @ d)
        q = quat_multiply(q, prep.dq[k])
        if prep.accel_ok[k] and vector:
            q = _update(ukf, points, q, prep.up[k], prep.up_var[k], lambda R, d: _direction(R, d, UP))
            n_acc += 1
            if prep.mag_ok[k]:
                q = _update(ukf, points, q, prep.field_dir[k], prep.field_var[k],
                            lambda R, d: _direction(R, d, field_nav))
                n_mag += 1
        elif prep.accel_ok[k]:
            up = prep.up[k]
            north = prep.north[k] if prep.mag_ok[k] else None
            z = np.append(up, 0.0) if north is not None else up
            var = [prep.up_var[k]] * 3 + ([prep.heading_var[k]] if north is not None else [])
            q = _update(ukf, points, q, z, var, lambda R, d: _measure(R, d, up, north))
            n_acc += 1
            n_mag += north is not None
        q = q / np.linalg.norm(q)
        quats.append(q)
        diag.append(np.diag(ukf.P).copy())
    return finish(setup, np.array(quats), np.array(diag), n_acc, n_mag)
