"""The covariance of B and the upper-triangular H of the norm-only fit `|H (y - B)| = g` (`fit_accel_upper`).

A pose's samples are not independent evidence about H beyond their mean: where the unit was placed, how the hand
wobbled and whatever the model misses are the same for all of them. So the covariance is taken at the level of the
pose means m_i: residuals r_i = |H (m_i - B)| - g, their Jacobian J in the 3 + 6 free parameters, and the
Gauss-Newton covariance of a least-squares estimate, cov = s^2 (J^T J)^-1 (Seber & Wild, Nonlinear Regression,
1989, sec. 2.1; Bjorck, Numerical Methods for Least Squares Problems, 1996, sec. 9.1). The variance s^2 is the
larger of the residual variance sum r_i^2 / (n - 9) and what the samples' own noise gives a pose mean along its
gravity direction (its standard error projected by u_i^T H): a fit that matches its poses closer than their noise
allows has been lucky, not precise.

With few poses the residual variance rests on n - 9 degrees of freedom (one with imu_tk's ten): it is then itself
uncertain by a factor of several. Its share is widened by Student's t, (t_{n-9, 0.8413})^2 (1.84^2 at one degree of
freedom), so that the stated deviation covers an error with the 68 % of a normal one sigma (Student, 1908): the
estimate over s is t-distributed, not normal.
"""

from __future__ import annotations

import numpy as np
from scipy.special import stdtrit

from rig.calibration.numerics.jackknife import one_step_deletions, scatter_to_stated

UPPER = np.triu_indices(3)
OUTSIDE_ONE_SIGMA = 0.31731050786291415  # the normal's P(|z| > 1)
FEW_DOF = 8                             # below, s from the residuals is uncertain by more than 1/sqrt(2 dof) = 25 %


def norm_fit_covariance(chunks: list[np.ndarray], B: np.ndarray, H: np.ndarray, norm: float
                        ) -> tuple[np.ndarray, np.ndarray, dict]:
    """B_cov (3, 3) and H_cov (9, 9, row-major vec(H), zero for the entries below the diagonal) of a norm-only fit
    to the static chunks [(m_i, 3) raw samples each], and what they rest on: the poses' degrees of freedom, the
    residual and noise variances (norm unit^2), the Student factor applied, and the scatter of the parameters over
    leave-one-pose-out refits against the deviation stated (`jackknife`)."""
    means = np.array([c.mean(axis=0) for c in chunks])
    d = means - B
    v = d @ H.T
    u = v / np.linalg.norm(v, axis=1, keepdims=True)
    r = np.linalg.norm(v, axis=1) - norm
    uH = u @ H                                                  # d r_i / d m_i
    J = np.hstack([-uH, u[:, UPPER[0]] * d[:, UPPER[1]]])       # d r_i / d (B, H[UPPER])
    noise = np.mean([uh @ np.cov(c, rowvar=False) @ uh / len(c) for uh, c in zip(uH, chunks)])
    dof = len(chunks) - J.shape[1]
    residual = float(r @ r / dof) if dof > 0 else np.inf
    factor = float(stdtrit(dof, 1.0 - OUTSIDE_ONE_SIGMA / 2)) ** 2 if dof > 0 else np.inf       # t_{dof, 0.8413}^2
    s2 = max(factor * residual, float(noise))
    scale = np.linalg.norm(J, axis=0)             # B's columns ~ H, H's ~ counts: (J^T J)^-1 unscaled loses all digits
    _, sv, Vt = np.linalg.svd(J / scale, full_matrices=False)
    cov = s2 * (Vt.T / sv ** 2) @ Vt / np.outer(scale, scale)
    full = np.zeros((12, 12))
    idx = np.r_[0:3, 3 + 3 * UPPER[0] + UPPER[1]]
    full[np.ix_(idx, idx)] = cov
    scatter = scatter_to_stated(one_step_deletions(J, r, [np.array([i]) for i in range(len(r))]),
                                np.sqrt(np.clip(np.diag(cov), 0, None)))
    return full[:3, :3], full[3:, 3:], {"dof": dof, "residual_var": residual, "noise_var": float(noise),
                                        "student_factor": factor, "variance": s2,
                                        "loo_scatter_to_predicted": scatter}


def stds(B_cov: np.ndarray, H_cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """B_std (3,) and H_std (3, 3) from their covariances."""
    return np.sqrt(np.clip(np.diag(B_cov), 0, None)), np.sqrt(np.clip(np.diag(H_cov), 0, None)).reshape(3, 3)


def stated_uncertainty(chunks: list[np.ndarray], B: np.ndarray, H: np.ndarray, norm: float
                       ) -> tuple[dict, dict, list[str]]:
    """The TriadCalibration fields (B_std, H_std, B_cov, H_cov), what they rest on (for `extra`) and a warning
    where they rest on few degrees of freedom (none stated without one: a fit through every pose shows no scatter)."""
    if len(chunks) <= 9:
        return {}, {"dof": len(chunks) - 9}, [f"{len(chunks)} poses for 9 unknowns: no residual to state B_std and "
                                              "H_std from"]
    B_cov, H_cov, info = norm_fit_covariance(chunks, B, H, norm)
    B_std, H_std = stds(B_cov, H_cov)
    led = "residuals" if info["student_factor"] * info["residual_var"] > info["noise_var"] else "sample noise"
    note = {"dof": info["dof"], "from": led, "student_factor": info["student_factor"],
            "residual_rms_pose_means": float(np.sqrt(info["residual_var"])),
            "noise_rms_pose_means": float(np.sqrt(info["noise_var"])),
            "loo_scatter_to_predicted": info["loo_scatter_to_predicted"]}
    if info["dof"] >= FEW_DOF:
        return {"B_std": B_std, "H_std": H_std, "B_cov": B_cov, "H_cov": H_cov}, note, []
    warnings = [f"B_std and H_std rest on {info['dof']} degree(s) of freedom ({len(chunks)} poses for 9 unknowns): "
                f"widened by Student's t (x{np.sqrt(info['student_factor']):.2f}), they are themselves uncertain by "
                f"about {1 / np.sqrt(2 * info['dof']):.0%} (1/sqrt(2 dof)); more poses make them firm"]
    return {"B_std": B_std, "H_std": H_std, "B_cov": B_cov, "H_cov": H_cov}, note, warnings
