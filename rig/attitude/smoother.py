"""A fixed-interval (Rauch-Tung-Striebel) smoother on the UKF's models: the non-causal bound of the validation.

Why: the UKF and the `ahrs` EKF end up within run-to-run scatter of each other on the simulated rig.
To tell "the filter is poor" from "both sit at what the data allow", this estimator uses every sample
of the record, past and future, with the same process and measurement models (`measurements.prepare`):
no causal filter on the same data and models can do better on average. Offline validation only.

Forward pass: the error-state Kalman filter of `ukf.py` in its first-order form ('vector' mode: gravity
direction, then field direction, `h(d) = Exp(-d) R^T v ~ g + [g]x d`). At the filter's covariances
(~0.02 deg) the measurement functions are linear to ~1e-8 rad over the sigma-point spread, so this pass
equals the UKF kernel (the tests hold it to that). Backward pass: RTS on the error rotation vector,
`d_k = G_k Log(R_pred,k+1^T R_s,k+1)`, `G_k = P_k A_k+1^T P_pred,k+1^-1`.
"""

from __future__ import annotations

import numpy as np

from rig.attitude.measurements import field_in_navigation
from rig.attitude.ukf import AttitudeEstimate, UKFSettings, finish, setup_filter
from rig.rotations import matrix_from_quat, matrix_from_rotvec, quat_from_matrix, rotvec_from_matrix, skew

UP = np.array([0.0, 0.0, 1.0])


def _update(R: np.ndarray, P: np.ndarray, z: np.ndarray, var: float, v_nav: np.ndarray):
    """First-order update with a unit body vector `z ~ R^T v_nav` (Joseph form)."""
    g = R.T @ v_nav
    H = skew(g)
    S = H @ P @ H.T + var * np.eye(3)
    K = np.linalg.solve(S, H @ P).T
    d = K @ (z - g)
    IKH = np.eye(3) - K @ H
    P = IKH @ P @ IKH.T + var * (K @ K.T)
    return R @ matrix_from_rotvec(d), 0.5 * (P + P.T)


def _forward(setup, vector_field: np.ndarray):
    prep = setup.prep
    n = len(setup.t)
    R = matrix_from_quat(setup.q0)
    P = setup.P0.copy()
    dR = matrix_from_quat(np.asarray(prep.dq))
    A = np.asarray(prep.A).reshape(n, 3, 3)
    Rp, Pp, Rf, Pf = (np.empty((n, 3, 3)) for _ in range(4))
    n_acc = n_mag = 0
    for k in range(n):
        R = R @ dR[k]
        P = A[k] @ P @ A[k].T + prep.q_var[k] * np.eye(3)
        Rp[k], Pp[k] = R, P
        if prep.accel_ok[k]:
            R, P = _update(R, P, prep.up[k], prep.up_var[k], UP)
            n_acc += 1
            if prep.mag_ok[k]:
                R, P = _update(R, P, prep.field_dir[k], prep.field_var[k], vector_field)
                n_mag += 1
        Rf[k], Pf[k] = R, P
    return Rp, Pp, Rf, Pf, A, n_acc, n_mag


def smooth_attitude(t, gyro, accel, mag=None, *, gravity: float = 9.80665, field_uT: float | None = None,
                    noise=None, still_rows=None, settings: UKFSettings | None = None,
                    forward_only: bool = False) -> AttitudeEstimate:
    """RTS-smoothed attitude on the inputs of `estimate_attitude` ('vector' magnetometer measurement).

    forward_only: return the first-order forward filter instead (to check it against the UKF kernel).
    """
    settings = settings or UKFSettings()
    if settings.mag_measurement != "vector":
        raise ValueError(f"the smoother implements the 'vector' magnetometer measurement, got {settings.mag_measurement!r}")
    setup = setup_filter(t, gyro, accel, mag, gravity=gravity, field_uT=field_uT, noise=noise,
                         still_rows=still_rows, settings=settings)
    field_nav = np.array(field_in_navigation(setup.dip_rad)) if np.isfinite(setup.dip_rad) else UP
    Rp, Pp, Rf, Pf, A, n_acc, n_mag = _forward(setup, field_nav)
    Rs, Ps = Rf.copy(), Pf.copy()
    if not forward_only:
        for k in range(len(setup.t) - 2, -1, -1):
            G = np.linalg.solve(Pp[k + 1], A[k + 1] @ Pf[k]).T
            d = G @ rotvec_from_matrix(Rp[k + 1].T @ Rs[k + 1])
            Rs[k] = Rf[k] @ matrix_from_rotvec(d)
            Ps[k] = Pf[k] + G @ (Ps[k + 1] - Pp[k + 1]) @ G.T
    diag = np.einsum("nii->ni", Ps)
    return finish(setup, quat_from_matrix(Rs), diag, n_acc, n_mag)
