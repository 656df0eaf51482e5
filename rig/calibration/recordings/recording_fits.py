"""The fits behind a recording without a turntable: what a hand-held session's faces and turns can tell.

Accelerometer from static poses, `H (y_k - B) = g u_k`: where a pose says which sensor axis was up, its gravity
direction `u_k` is that axis tilted by a small unknown angle with the prior standard deviation the procedure
gives (`tilt_deg_sd`: a hand-placed face is not at its nominal attitude, and taking it as exact puts the tilt
into H); a pose without that knowledge only says `|H (y_k - B)| = g`. Maximum a posteriori over B, H and the
tilts (Levenberg-Marquardt, MINPACK's); the faces' priors fix the orientation of the frame that the norms alone
leave free.

Gyroscope: B from the static poses; H from what the recording knows of its motions. A turn of known angle
about a sensor axis (imucal's Ferraris turns) gives `H m_k = theta_k a_k` with `m_k` the summed raw rate: the
component along the axis to within the turn's `angle_deg_sd`, the components across it to within the angle
times the face tilt (a hand turn's axis wanders as a face does). A motion between two static poses carries the
gravity direction of one onto the other (imu_tk's criterion, `R^T g_0 = g_1`), which fixes what turns leave
open. Both enter one weighted least-squares fit; a motion's miss is weighed along its axis and across it apart
(`carry_weight`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.recordings.carry_weight import PRIOR, CarryWeight, angle_directions, weighted_miss
from rig.calibration.turntable.gyro import MoveSet, decimated, integrated_quats
from rig.calibration.numerics.jackknife import one_step_deletions, scatter_to_stated
from rig.errors import CalibrationError
from rig.session_data import MoveStream

AXIS_VECTORS = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1),
                "-z": (0, 0, -1)}
MEAN_SE_FLOOR = 1e-4          # relative to the norm: the least a pose mean is trusted to (model error)
START_STRIDE = 8              # the start's coarse scale search integrates every 8th sample
# The gyro fit's Jacobian (H over its mean scale, entries about 1) is not taken again for a step smaller than this:
# from a start at the recording's H a replica's fit steps 4e-4, then 2e-6 and 3e-9, and the Jacobian changes by
# about the step, so the last steps cost ten integrations of every motion each for nothing. Measured on the two
# real recordings' replicas and held-out refits: H moves by at most 1.1e-8 of itself (its standard deviation is
# 9e-4 of it), a held-out angle by at most 1.5e-6 deg, for 20 % (replicas) to 37 % (imucal's held-out refits)
# less CPU.
JAC_REUSE = 1e-5


def tangent_basis(u: np.ndarray) -> np.ndarray:
    """Two unit vectors perpendicular to each u (..., 3) -> (..., 2, 3)."""
    u = np.asarray(u, dtype=float)
    a = np.where((np.abs(u[..., :1]) < 0.9), [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(u, a)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return np.stack([e1, np.cross(u, e1)], axis=-2)


def tilted(u: np.ndarray, d: np.ndarray, basis: np.ndarray | None = None) -> np.ndarray:
    """Each u (k, 3) turned by the small rotation of its tangent components d (k, 2): exactly |d| rad towards
    the tangent direction (Rodrigues)."""
    u = np.atleast_2d(np.asarray(u, dtype=float))
    d = np.atleast_2d(np.asarray(d, dtype=float))
    basis = tangent_basis(u) if basis is None else basis
    v = np.einsum("ki,kij->kj", d, basis)
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    direction = np.divide(v, angle, out=np.zeros_like(v), where=angle > 0)
    return u * np.cos(angle) + direction * np.sin(angle)


def tilted_jacobian(u: np.ndarray, d: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """d tilted(u, d, basis)_k / d d_k, (k, 3, 2): Rodrigues' turn of u by v = d basis differentiated in v,
    `-u sinc(t) v^T + sinc(t) (I - n n^T) + cos(t) n n^T` with t = |v| and n = v / t (the identity at t = 0)."""
    v = np.einsum("ki,kij->kj", d, basis)
    t = np.linalg.norm(v, axis=-1)
    n = np.divide(v, t[:, None], out=np.zeros_like(v), where=t[:, None] > 0)
    sinc = np.sinc(t / np.pi)
    nn = n[:, :, None] * n[:, None, :]
    dv = (-sinc[:, None, None] * u[:, :, None] * v[:, None, :] + sinc[:, None, None] * (np.eye(3) - nn)
          + np.cos(t)[:, None, None] * nn)
    return dv @ np.swapaxes(basis, 1, 2)


def fit_faces(means: np.ndarray, se: np.ndarray, ups: list[str | None], tilt_sd_rad: np.ndarray,
              norm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """B, H, the fitted gravity directions u_k (k, 3) and details, from pose means (k, 3) with standard errors.

    At least three poses must say which axis was up (their priors fix the frame); the others enter by their
    norm only.
    """
    means = np.asarray(means, dtype=float)
    known = [i for i, u in enumerate(ups) if u is not None]
    if len(known) < 3:
        raise CalibrationError(f"accel: {len(known)} poses say which axis was up; the face model needs 3")
    if len(means) < 5:
        raise CalibrationError(f"accel: {len(means)} static poses; at least 5 are needed for B and H with the face "
                               "priors")
    nominal = np.array([AXIS_VECTORS[ups[i]] for i in known], dtype=float)
    # start: linear least squares of H y_k - c = g e_k over the poses with a known face (c = H B)
    A = np.hstack([means[known], -np.ones((len(known), 1))])
    X, *_ = np.linalg.lstsq(A, norm * nominal, rcond=None)
    H0, c0 = X[:3].T, X[3]
    if not np.linalg.det(H0) > 0:
        raise CalibrationError("accel: the faces do not span three axes with a right-handed sensor")
    B0 = np.linalg.solve(H0, c0)
    scale = float(np.abs(np.diag(H0)).mean())
    se = np.asarray(se, dtype=float)
    n_known = len(known)
    unknown = [i for i in range(len(means)) if ups[i] is None]

    def unpack(p):
        return p[:3], p[3:12].reshape(3, 3) * scale, p[12:].reshape(n_known, 2)

    basis = tangent_basis(nominal)

    def residuals(p):
        B, H, d = unpack(p)
        a = (means - B) @ H.T
        u = tilted(nominal, d, basis)
        s = sigma_phys(H)
        r_face = ((a[known] - norm * u) / s[known]).ravel()
        r_norm = (np.linalg.norm(a[unknown], axis=1) - norm) / np.linalg.norm(s[unknown], axis=1) if unknown else []
        return np.concatenate([r_face, r_norm, (d / tilt_sd_rad[known][:, None]).ravel()])

    def sigma_phys(H):
        """Standard error of each pose's calibrated mean, at least the floor for what the model leaves out."""
        return np.maximum(np.sqrt((se ** 2) @ (H ** 2).T), MEAN_SE_FLOOR * norm)

    def jacobian(p):
        """d residuals / d p, analytic: every residual is a ratio of a pose's calibrated mean (linear in B and
        H) to its standard error (which grows with H unless floored)."""
        B, H, d = unpack(p)
        y = means - B
        a = y @ H.T
        s = sigma_phys(H)
        free = np.sqrt((se ** 2) @ (H ** 2).T) > MEAN_SE_FLOOR * norm
        k = len(means)
        da = np.zeros((k, 3, 12))                                   # d a_ki / d (B, H / scale)
        da[:, :, :3] = -H
        for i in range(3):
            da[:, i, 3 + 3 * i:6 + 3 * i] = y * scale
        ds = np.zeros((k, 3, 12))                                   # d s_ki / d (H / scale)
        for i in range(3):
            ds[:, i, 3 + 3 * i:6 + 3 * i] = np.where(free[:, i:i + 1], se ** 2 * H[i] / s[:, i:i + 1] * scale, 0.0)
        J = np.zeros((3 * n_known + len(unknown) + 2 * n_known, len(p)))
        e = (a[known] - norm * tilted(nominal, d, basis))            # (n_known, 3)
        sk = s[known]
        face = da[known] / sk[:, :, None] - (e / sk ** 2)[:, :, None] * ds[known]
        J[:3 * n_known, :12] = face.reshape(-1, 12)
        du = tilted_jacobian(nominal, d, basis)                    # (n_known, 3, 2)
        for j in range(n_known):
            J[3 * j:3 * j + 3, 12 + 2 * j:14 + 2 * j] = -norm * du[j] / sk[j][:, None]
        if unknown:
            au, su = a[unknown], s[unknown]
            na, ns = np.linalg.norm(au, axis=1), np.linalg.norm(su, axis=1)
            dna = np.einsum("ki,kij->kj", au / na[:, None], da[unknown])
            dns = np.einsum("ki,kij->kj", su / ns[:, None], ds[unknown])
            J[3 * n_known:3 * n_known + len(unknown), :12] = dna / ns[:, None] - ((na - norm) / ns ** 2)[:, None] * dns
        rows = 3 * n_known + len(unknown) + np.arange(2 * n_known)
        J[rows, 12 + np.arange(2 * n_known)] = 1.0 / np.repeat(tilt_sd_rad[known], 2)
        return J

    p0 = np.concatenate([B0, (H0 / scale).ravel(), np.zeros(2 * n_known)])
    res = least_squares(residuals, p0, jac=jacobian, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14,
                        max_nfev=2000)
    B, H, d = unpack(res.x)
    u = np.zeros_like(means)
    a = (means - B) @ H.T
    u[known] = tilted(nominal, d, basis)
    for i in unknown:
        u[i] = a[i] / np.linalg.norm(a[i])
    J = res.jac
    dof = max(J.shape[0] - J.shape[1], 1)
    cov = np.linalg.pinv(J.T @ J) * max(float(res.fun @ res.fun) / dof, 1.0)
    cov_BH = cov[:12, :12] * np.r_[np.ones(3), np.full(9, scale)][:, None] * np.r_[np.ones(3), np.full(9, scale)][None]
    tilt_deg = np.zeros(len(means))
    tilt_deg[known] = np.degrees(np.linalg.norm(d, axis=1))
    return B, H, u, {"tilt_deg": tilt_deg.tolist(), "cov": cov_BH, "converged": bool(res.success),
                     "iterations": int(res.nfev)}


def gyro_rotation_fit(B: np.ndarray, turns: list[tuple[np.ndarray, np.ndarray, float, float, float]],
                      carries: list[tuple[MoveStream, np.ndarray, np.ndarray]], H0: np.ndarray | None = None,
                      carry: CarryWeight = PRIOR) -> tuple[np.ndarray, np.ndarray, dict]:
    """H and its covariance from turns [(m_k summed raw rate * dt (3,), nominal axis (3,), angle rad, angle sd rad,
    axis sd rad)] and motions carrying gravity [(raw stream, g_start unit, g_end unit)], each motion's miss trusted
    as `carry` says (along its angle directions at H0). The covariance is the scatter the residuals show
    (`scattered_cov`): at least the stated under the prior weight, as it comes under a weight the data chose
    (`carry_choice.carry_weight_by_cross_validation`).
    info's `left_out_H`: H without each turn, then each motion, one Gauss-Newton step from this fit
    (`jackknife.one_step_deletions`; None where a piece cannot be left out), and `loo_scatter_to_predicted` their
    scatter against the deviation this covariance states."""
    if not turns and not carries:
        raise CalibrationError("gyro: no turn of known angle and no motion between static poses to calibrate H from")
    ms = MoveSet.build([c[0] for c in carries], B) if carries else None
    g0 = np.array([c[1] for c in carries]).reshape(-1, 3)
    g1 = np.array([c[2] for c in carries]).reshape(-1, 3)
    equations = 3 * len(turns) + 3 * len(carries)
    if equations < 9:
        raise CalibrationError(f"gyro: {len(turns)} turns and {len(carries)} motions between poses give {equations} "
                               "equations for H's 9 entries")
    if H0 is None:
        coarse = MoveSet.build(decimated([c[0] for c in carries], START_STRIDE), B) if carries else None
        H0 = _start(turns, coarse, g0, g1)
    scale = float(np.abs(np.diag(H0)).mean()) or 1.0

    M = np.array([m for m, *_ in turns]).reshape(-1, 3)
    axes = np.array([a for _, a, *_ in turns]).reshape(-1, 3)
    angles = np.array([t[2] for t in turns])
    along_sd = np.array([t[3] for t in turns])
    across_sd = np.array([abs(t[2]) * t[4] for t in turns])
    angle_dirs = angle_directions(integrated_quats(H0, ms), g1) if ms is not None and not carry.isotropic else None

    def stacked(X: np.ndarray) -> np.ndarray:
        """Residuals of a stack of H (n, 3, 3) -> (n, m): turns first, then the carried gravity."""
        parts = []
        if len(M):
            w = np.einsum("nij,kj->nki", X, M)                                   # (n, turns, 3)
            along = np.einsum("nki,ki->nk", w, axes)
            across = w - along[..., None] * axes
            parts += [((along - angles) / along_sd), (across / across_sd[:, None]).reshape(len(X), -1)]
        if ms is not None:
            q = integrated_quats(X, ms)
            parts.append(weighted_miss(_rotate_inverse(q, g0) - g1, angle_dirs, carry).reshape(len(X), -1))
        return np.concatenate(parts, axis=1)

    last: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def fun(x):
        r = stacked(x.reshape(1, 3, 3) * scale)[0]
        last["fun"] = (x.copy(), r)
        return r

    def jac(x, step: float = 1e-7):
        """Forward differences, each an integration of every motion. The residuals at x itself are the ones `fun`
        just gave; a Jacobian taken within JAC_REUSE of x is x's (module constant: why)."""
        if "jac" in last and np.max(np.abs(x - last["jac"][0])) <= JAC_REUSE:
            return last["jac"][1]
        at, r0 = last.get("fun", (None, None))
        if at is not None and np.array_equal(at, x):
            r = stacked((x + step * np.eye(9)).reshape(-1, 3, 3) * scale)
            J = ((r - r0) / step).T
        else:
            r = stacked(np.vstack([x, x + step * np.eye(9)]).reshape(-1, 3, 3) * scale)   # one call for all ten
            J = ((r[1:] - r[0]) / step).T
        last["jac"] = (x.copy(), J)
        return J

    res = least_squares(fun, (H0 / scale).ravel(), jac=jac, method="lm", xtol=1e-13, ftol=1e-13, gtol=1e-13,
                        max_nfev=400)
    H = res.x.reshape(3, 3) * scale
    J = res.jac
    n_turns = len(M)
    kinds = [slice(0, n_turns), slice(n_turns, 4 * n_turns), slice(4 * n_turns, len(res.fun))]
    cov = scattered_cov(J, res.fun, kinds, floor=carry == PRIOR) * scale * scale
    groups = [np.r_[k, n_turns + 3 * k:n_turns + 3 * k + 3] for k in range(n_turns)] + \
             [4 * n_turns + np.arange(3 * c, 3 * c + 3) for c in range(len(carries))]
    deletions = one_step_deletions(J, res.fun, groups)
    scatter = scatter_to_stated(deletions, np.sqrt(np.diag(cov)) / scale)
    return H, cov, {"converged": bool(res.success), "iterations": int(res.nfev), "rank": int(np.linalg.matrix_rank(J)),
                    "moveset": ms, "loo_scatter_to_predicted": scatter,
                    "left_out_H": None if deletions is None else H + deletions.reshape(-1, 3, 3) * scale}


def scattered_cov(J: np.ndarray, r: np.ndarray, kinds: list[slice], floor: bool) -> np.ndarray:
    """The covariance of a weighted least-squares fit (Jacobian J and residuals r in standard deviations) under the
    scatter its residuals show, kind by kind (turn angles, turn axes, motions): the sandwich A^-1 J^T S J A^-1 with
    A = J^T J and S each kind's chi-square per degree of freedom (its rows less their leverage). A kind whose
    residuals the fit absorbs (three turns fix three scales exactly once the motions' angles are let go) shows no
    scatter and keeps the deviation its segments state, where one chi-square for all had shrunk it with the
    others'; a row no parameter moves (a turn's miss across a nominal axis has no part along it) is no degree of
    freedom. `floor`: no kind is trusted beyond its stated deviation (under the prior weight, which nothing chose
    from the data)."""
    inv = np.linalg.pinv(J.T @ J)
    leverage = np.einsum("ij,jk,ik->i", J, inv, J)
    variance = np.ones(len(r))
    for rows in kinds:
        dof = int(np.any(J[rows] != 0, axis=1).sum()) - float(leverage[rows].sum())
        if dof > 0.5:
            chi2 = float(r[rows] @ r[rows]) / dof
            variance[rows] = max(chi2, 1.0) if floor else chi2
    return inv @ (J.T * variance) @ J @ inv


def turn_angle(H: np.ndarray, m: np.ndarray, axis: np.ndarray) -> float:
    """The angle (rad) a turn's summed raw rate makes about its nominal axis under H."""
    return float((H @ m) @ axis)


def carried_errors(H: np.ndarray, B: np.ndarray, streams: list[MoveStream], g0: np.ndarray, g1: np.ndarray,
                   moveset: MoveSet | None = None) -> np.ndarray:
    """Angles (rad) between the gravity directions carried across motions by H and those measured after them;
    `moveset`: the streams already built with B (a fit's own), which is most of the cost."""
    if not streams:
        return np.zeros(0)
    q = integrated_quats(H, moveset if moveset is not None else MoveSet.build(streams, B))
    v = _rotate_inverse(q, np.asarray(g0))
    cos = np.einsum("ij,ij->i", v, np.asarray(g1)) / np.linalg.norm(v, axis=1)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def _start(turns, ms, g0, g1) -> np.ndarray:
    """imucal's closed form when three turns span the axes; else the best scalar multiple of I."""
    if len(turns) >= 3:
        M = np.array([m for m, *_ in turns])
        target = np.array([angle * axis for _, axis, angle, *_ in turns])
        X, *_ = np.linalg.lstsq(M, target, rcond=None)
        H = X.T
        if np.linalg.det(H) > 0:
            return H
    scales = np.exp(np.linspace(np.log(1e-6), np.log(10.0), 160))
    cost = np.zeros_like(scales)
    for m, axis, angle, angle_sd, _ in turns:
        cost += (scales * (m @ axis) - angle) ** 2
    if ms is not None:
        for chunk in np.array_split(np.arange(len(scales)), 8):         # all candidates at once, in chunks
            q = integrated_quats(scales[chunk, None, None] * np.eye(3), ms)
            cost[chunk] += np.sum((_rotate_inverse(q, g0) - g1) ** 2, axis=(-1, -2)) * 100.0
    return float(scales[int(np.argmin(cost))]) * np.eye(3)


def _rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q)^T v for quaternions q (..., n, 4) and vectors v (n, 3)."""
    w, u = q[..., :1], -q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)
