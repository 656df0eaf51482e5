"""The `Int` operator of the gyroscope step (Zhang 2015, eqs. 52-55): body rates -> rotation over a move.

The paper integrates the calibrated rates `H (y - B)` with a quaternion update between samples. Here
each sample interval uses the 4th-order Magnus expansion with two Gauss points, which for rates that
are linear in time between samples (the usual model of a sampled rate) collapses to the closed form

    phi_k = h (w_k + w_{k+1}) / 2 + h^2 / 12 (w_k x w_{k+1})           (rotation vector of interval k)

so no sub-steps are needed; its local error is O(h^5) and it is exact for constant rates. The
interval quaternions are multiplied in a balanced tree (log2(m) vectorised levels), which lets one
call integrate a whole stack of rate histories, e.g. all sigma points of the UKF at once.

Convention (conventions.md): rates are in the fixture frame, so the orientation evolves as
`R' = R [w x]` and the result is the body rotation over the interval, `R(t0)^T R(t_end)`.
"""

from __future__ import annotations

import numpy as np

from rig.rotations import matrix_from_quat


def interval_rotvecs(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., m-1, 3) of each sample interval (Magnus order 4, linear rates)."""
    h = np.diff(np.asarray(t, dtype=float))[:, None]
    w0, w1 = omega[..., :-1, :], omega[..., 1:, :]
    return 0.5 * h * (w0 + w1) + (h * h / 12.0) * np.cross(w0, w1)


def quat_exp(phi: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion of rotation vectors phi (..., 3)."""
    angle = np.linalg.norm(phi, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(x/2)/x without 0/0: the series is accurate to 1e-17 below 1e-4 rad.
    small = angle < 1e-4
    safe = np.where(small, 1.0, angle)
    k = np.where(small, 0.5 - angle * angle / 48.0, np.sin(half) / safe)
    return np.concatenate([np.cos(half), k * phi], axis=-1)


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    w2, x2, y2, z2 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ], -1)


def ordered_product(q: np.ndarray) -> np.ndarray:
    """q_0 q_1 ... q_{n-1} over axis -2 of (..., n, 4), by pairwise (associative) reduction."""
    while q.shape[-2] > 1:
        if q.shape[-2] % 2:
            ident = np.zeros(q.shape[:-2] + (1, 4))
            ident[..., 0] = 1.0
            q = np.concatenate([q, ident], axis=-2)
        q = _qmul(q[..., 0::2, :], q[..., 1::2, :])
    return q[..., 0, :]


def integrate_quaternion(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Scalar-first quaternion(s) (..., 4) of R(t0)^T R(t_end) for rates omega (..., m, 3) on times t (m,)."""
    t = np.asarray(t, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if t.ndim != 1 or omega.shape[-2:] != (t.size, 3):
        raise ValueError(f"integrate: t has shape {t.shape}, omega {omega.shape}; need t (m,) and omega (..., m, 3)")
    if t.size < 2:
        q = np.zeros(omega.shape[:-2] + (4,))
        q[..., 0] = 1.0
        return q
    if np.any(np.diff(t) <= 0):
        bad = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise ValueError(f"integrate: time stamps must increase; t[{bad}]={t[bad]!r} >= t[{bad + 1}]={t[bad + 1]!r}")
    q = ordered_product(quat_exp(interval_rotvecs(t, omega)))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def integrate_rotation(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Body rotation R(t0)^T R(t_end) (3, 3) (or stacked (..., 3, 3)) from fixture-frame rates in rad/s."""
    return matrix_from_quat(integrate_quaternion(t, omega))
