"""The fit behind a recording's magnetometer: a sphere through every sample, turned onto the accelerometer's frame.

Without a reference attitude, the field's magnitude is the same at every sample (`|H (y - B)| = M`) and its angle
to gravity is the same in every still pose (`g_k . v_k / |v_k| = sin(dip)`, `v_k = H (m_k - B)`). The first fixes
B and the symmetric part of H from all the samples a recording's motions sweep over the sphere (its six faces alone
cannot: nine entries and three offsets from six points); the second fixes the rotation, so the magnetometer's
output is in the frame the accelerometer and gyroscope share (conventions.md). Both are fitted together by least
squares, each group weighted by its own residual scatter, which the covariance then states. The
residuals and their Jacobian: `mag_model`; the groups' noise and the magnitudes' bias: `fit_noise`.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.numerics.ellipsoid import fit_ellipsoid, sphere_map
from rig.calibration.numerics.fit_noise import group_sigmas, sphere_noise_bias
from rig.calibration.numerics.mag_model import jacobian, residuals
from rig.rotations import axis_angle_matrix, skew

SIGMA_FLOOR = 1e-4                 # of the field: the least a residual is trusted to (model error)


def signed_permutations() -> list[np.ndarray]:
    """The 24 axis swaps and sign flips with det +1: a chip mounted turned against the accelerometer (an MPU-9250's
    AK8963 has x and y swapped and z reversed, which is one of them), where alignment starts."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            P = np.zeros((3, 3))
            P[range(3), perm] = signs
            if np.linalg.det(P) > 0:
                out.append(P)
    return out


def sphere_start(y: np.ndarray, norm: float) -> tuple[np.ndarray, np.ndarray]:
    """B and the symmetric H that map the samples' ellipsoid onto the sphere of radius `norm`."""
    fit = fit_ellipsoid(y, what="mag", check_repeats=False)
    return fit.center, sphere_map(fit, norm)


def best_rotation(S: np.ndarray, B: np.ndarray, groups: list[tuple[np.ndarray, np.ndarray]],
                  norm: float) -> tuple[np.ndarray, float]:
    """The rotation Q from the best start for which each group's fields make one angle with its
    direction, and the RMS of that angle's scatter it leaves (rad). A group is (raw field rows (n, 3), unit
    directions (n, 3)): the still poses with their gravity, or the samples of a turn with its axis."""
    # d . (Q v) = vec(Q) . vec(d v^T): each row's products, less its group's mean, make every angle's
    # scatter about its group's one linear in Q
    outer = np.vstack([(d[:, :, None] * ((y - B) @ S.T / norm)[:, None, :]).reshape(-1, 9) for y, d in groups])
    group = np.repeat(np.arange(len(groups)), [len(d) for _, d in groups])
    means = np.stack([np.bincount(group, outer[:, j]) for j in range(9)], axis=1) / np.bincount(group)[:, None]
    # |C vec(Q)| = |R vec(Q)| with C = QR: each start's fit then handles 9 numbers, not one per sample
    triangle = np.linalg.qr(outer - means[group], mode="r")
    best, best_rms = None, np.inf
    for P in signed_permutations():
        def fun(x, P=P):
            return triangle @ (_rotation(x) @ P).ravel()

        def jac(x, P=P):
            return triangle @ _rotated_columns_jacobian(x, P)
        res = least_squares(fun, np.zeros(3), jac=jac, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                            max_nfev=200)
        rms = float(np.sqrt(res.fun @ res.fun / len(group)))
        if rms < best_rms:
            best, best_rms = _rotation(res.x) @ P, rms
    return best, best_rms


def joint_fit(y: np.ndarray, groups: list[tuple[np.ndarray, np.ndarray]], norm: float, B: np.ndarray,
              H: np.ndarray, turn_sd: list[float] = ()) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """B, H, their covariance (12, 12: B then row-major H) and details, from samples y (n, 3) and the groups of
    `best_rotation` (the first the still poses, then the turns with their axes' standard deviations `turn_sd`,
    rad), starting at B, H. Each is weighted by its own noise (`fit_noise.group_sigmas`); a turn's at least what
    its axis's uncertainty makes of its samples, which all share that one axis (400 samples trusted as
    independent pulled H 1 % out of shape)."""
    n = [len(y)] + [len(g[0]) for g in groups]
    kinds = np.repeat(np.arange(len(n)), n)
    floors = np.full(len(n), SIGMA_FLOOR)
    sigma = np.ones(len(n))
    for _ in range(2):                  # the weights from the first pass's residuals, then the fit again
        for k, sd in enumerate(turn_sd, start=2):
            v = (groups[k - 1][0] - B) @ H.T / norm
            across = np.linalg.norm(np.cross(v, groups[k - 1][1]), axis=1)
            floors[k] = sd * float(np.sqrt(np.mean(across ** 2) * n[k] / 2))
        w = 1.0 / np.maximum(sigma, floors)[kinds]
        p0 = np.concatenate([B, H.ravel() / norm, [float(np.mean(((gy - B) @ H.T * d).sum(axis=1))) / norm
                                                   for gy, d in groups]])
        res = least_squares(lambda p: residuals(p, y, groups) * w, p0,
                            jac=lambda p: jacobian(p, y, groups) * w[:, None],
                            method="lm", xtol=1e-13, ftol=1e-13, gtol=1e-13, max_nfev=200)
        B, H = res.x[:3], res.x[3:12].reshape(3, 3) * norm
        r = res.fun / w
        noise = sigma = group_sigmas(r, jacobian(res.x, y, groups) * w[:, None], kinds)
    sigma = np.maximum(noise, floors)
    w = 1.0 / sigma[kinds]
    J0 = jacobian(res.x, y, groups)
    J = J0 * w[:, None]
    inv = np.linalg.pinv(J.T @ J)
    x = res.x + inv[:, :12] @ sphere_noise_bias(J0[kinds == 0, :12], float(noise[0])) * w[0] ** 2
    B, H = x[:3], x[3:12].reshape(3, 3) * norm
    scale = np.r_[np.ones(3), np.full(9, norm)]
    cov = inv[:12, :12] * scale[:, None] * scale[None]
    rms = [float(np.sqrt(np.mean(r[kinds == k] ** 2))) for k in (0, 1)]
    sine = float(np.clip(-x[12], -1, 1))
    dip_sd = float(np.sqrt(max(inv[12, 12], 0.0)) / max(np.sqrt(1.0 - sine * sine), 1e-12))   # d asin(s) = ds / cos
    return B, H, cov, {"norm_rms": rms[0] * norm, "dip_deg": float(np.degrees(np.arcsin(sine))),
                       "dip_std_deg": float(np.degrees(dip_sd)),
                       "dot_rms": rms[1], "iterations": int(res.nfev), "converged": bool(res.success)}


def _rotation(x: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(x))
    return np.eye(3) if angle == 0 else axis_angle_matrix(x / angle, angle)


def _rotated_columns_jacobian(x: np.ndarray, P: np.ndarray) -> np.ndarray:
    """d vec(R(x) P) / dx (9, 3), row-major vec, R(x) = exp([x]x): each column p of P turns as
    d(R p)/dx = -R [p]x J_r(x), with SO(3)'s right Jacobian J_r = I - a [x]x + b [x]x^2,
    a = (1 - cos t) / t^2, b = (t - sin t) / t^3 (their series below t = 1e-4)."""
    t = float(np.linalg.norm(x))
    a, b = ((1 - np.cos(t)) / t ** 2, (t - np.sin(t)) / t ** 3) if t > 1e-4 else (0.5 - t * t / 24, 1 / 6 - t * t / 120)
    K = skew(x)
    right = np.eye(3) - a * K + b * K @ K
    R = _rotation(x)
    return np.stack([-R @ skew(P[:, j]) @ right for j in range(3)], axis=1).reshape(9, 3)
