"""Accelerometer and magnetometer B and H from the holds and the samples taken while the table turns.

A hold mean and a sample of a move measure the same thing, `y = K u + B + e` (joint.py), at a known orientation:
the move's reference orientation on its row (`q_ref`, the table's encoders interpolated between polls). Two
things differ. The input: for the accelerometer `u = R^T G e_z + w' x r + w x (w x r)` (lever_arm.py; the arm r
from the pipeline's fit, w from the calibrated gyro), for the magnetometer `u = R^T m`. And time: a sample
stamped t may have been taken at t - delta (a chip's own sample clock, a filter's delay); while the table
turns at w that reads as `u(t - delta) = u + delta w x u` to first order, so delta is fitted with the others,
one per stretch of uninterrupted sampling (a chip on its own sample clock keeps its phase to the rig's tick grid
only while the grid runs: after a stall or a resumed run a magnetometer read every second tick may be up to 10 ms
off another way, 0.5 uT at the rates of a move). A single offset costs the bound nothing (the moves determine it
to ~20 us on the default session); one per move would cost 1-2.5 % of the H bound. Each move sample carries
the sensor's per-sample noise (the holds' spread), each hold mean its standard error, so the Fisher information
adds up and the maximum-likelihood fit is one weighted least squares over (B, H, the reference's two tilts, the
offsets), started from the hold-only joint fit.

What it gains is measured by the Cramer-Rao bound (planner_bounds.vector_bound with move paths): on the
default 20-orientation session the accelerometer's and magnetometer's H bound falls to 0.89 of the holds'
alone, on a 63 s plan of 20 short holds to 0.75.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.turntable.observability import tangent_basis
from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError

N_FIXED = 14   # B (3) + H (9) + direction of v (2); then one sample-time offset per label of MoveSamples.move
MAX_OFFSET_S = 0.05   # a fitted delta beyond this is no timing offset but a misfit: the move samples are refused
OFFSET_STD_S = 0.002  # a stretch of sampling that fixes its offset no better than this shares its neighbour's
REWEIGHT_ABOVE = 1.1  # move residuals scattered beyond this many times the sensor's noise: weighted by their scatter


@dataclass
class MoveSamples:
    """Move rows of one sensor: raw samples, the reference on their rows and what the input adds there."""

    y: np.ndarray          # (m, 3) raw counts
    R: np.ndarray          # (m, 3, 3) fixture -> world reference on the row
    omega: np.ndarray      # (m, 3) the fixture's rate (rad/s, fixture frame) on the row, for the time offset
    extra: np.ndarray      # (m, 3) input beyond R^T v (calibrated units): the lever arm's specific force
    sigma: np.ndarray      # (3,) noise of one sample, counts
    move: np.ndarray | None = None   # (m,) label of the rows sharing one time offset; None: all of them

    def __len__(self) -> int:
        return len(self.y)

    def labels(self) -> np.ndarray:
        if self.move is None:
            return np.zeros(len(self.y), dtype=int)
        return np.unique(np.asarray(self.move), return_inverse=True)[1].reshape(-1)


def calibrate_with_moves(hold_fit: TriadCalibration, y_means: np.ndarray, R: np.ndarray, sigma_holds: np.ndarray,
                         norm: float, moves: MoveSamples) -> TriadCalibration:
    """Maximum likelihood over the hold means (standard errors `sigma_holds` (n, 3)) and the move samples,
    from the hold-only fit `hold_fit` (its B, H and extra["reference_world"]). Raises CalibrationError where
    the fit fails or the samples misfit the model (a time offset beyond MAX_OFFSET_S).

    Rows of one `moves.move` label share a sample-time offset.
    The move samples are weighted by the sensor's noise, or by their own scatter about the fit where that is
    larger (a reference noisier than the encoders, an optical tracker's; the lever arm's specific force from a
    differentiated gyro): fitted once, the scatter of the move residuals per axis measured, fitted again."""
    fit = _fit(hold_fit, y_means, R, sigma_holds, norm, moves)
    scatter = np.sqrt(np.mean(np.square(fit.extra.pop("_move_residuals")), axis=0))
    if np.all(scatter <= moves.sigma * REWEIGHT_ABOVE):
        return fit
    heavier = MoveSamples(moves.y, moves.R, moves.omega, moves.extra, np.maximum(moves.sigma, scatter), moves.move)
    fit = _fit(hold_fit, y_means, R, sigma_holds, norm, heavier)
    fit.extra.pop("_move_residuals")
    fit.extra["move_sample_sigma"] = np.maximum(moves.sigma, scatter).tolist()
    return fit


def offset_information(label: np.ndarray, omega: np.ndarray, x: np.ndarray, K: np.ndarray,
                       sigma: np.ndarray) -> np.ndarray:
    """Fisher information (1/s^2) of each label's sample-time offset delta in `u + delta w x u`: the rows'
    `K (w x x) / sigma` squared and summed. Zero where the table stands still: there delta changes nothing."""
    if len(label) == 0:
        return np.zeros(0)
    return np.bincount(label, weights=np.sum((np.cross(omega, x) @ K.T / sigma) ** 2, axis=1),
                       minlength=int(label.max()) + 1)


def observable_labels(label: np.ndarray, omega: np.ndarray, x: np.ndarray, K: np.ndarray,
                      sigma: np.ndarray) -> np.ndarray:
    """The offset labels with every stretch that cannot fix its own offset (a few rows, or rows where the table
    hardly turns: a stall at the end of a move starts a stretch of still rows) joined to the stretch before it
    (the first to the next): its offset moves the fit by nothing, and left free it wandered to 1e11 ms and had
    every move sample refused (fault campaign). A stretch keeps its own offset where it determines it to
    OFFSET_STD_S or better (the Fisher information of delta in `u + delta w x u`). Where none does, all share one
    (which `_fit` refuses when even all the rows together do not fix it)."""
    if len(label) == 0:
        return label
    own = offset_information(label, omega, x, K, sigma) * OFFSET_STD_S ** 2 >= 1.0
    if not own.any():
        return np.zeros_like(label)
    keep = np.flatnonzero(own)
    target = keep[np.clip(np.searchsorted(keep, np.arange(len(own)), side="right") - 1, 0, None)]
    return np.unique(target, return_inverse=True)[1][label]


def _fit(hold_fit: TriadCalibration, y_means: np.ndarray, R: np.ndarray, sigma_holds: np.ndarray,
         norm: float, moves: MoveSamples) -> TriadCalibration:
    v0 = np.asarray(hold_fit.extra["reference_world"], dtype=float)
    Y = np.vstack([np.asarray(y_means, dtype=float), moves.y])
    RR = np.concatenate([np.asarray(R, dtype=float), moves.R])
    n = len(y_means)
    W = np.zeros((len(Y), 3))
    W[n:] = moves.omega
    C = np.zeros((len(Y), 3))
    C[n:] = moves.extra
    S = np.vstack([np.broadcast_to(sigma_holds, (n, 3)), np.broadcast_to(moves.sigma, (len(moves), 3))])
    x0, K0 = np.einsum("kji,j->ki", moves.R, v0), np.linalg.inv(hold_fit.H)
    label = observable_labels(moves.labels(), moves.omega, x0, K0, moves.sigma)
    groups = int(label.max()) + 1 if len(label) else 0
    info = offset_information(label, moves.omega, x0, K0, moves.sigma)
    if groups and info.min() * OFFSET_STD_S ** 2 < 1.0:
        # Rows where the table stands still (in a mixed rig whose chips see the table late, the only rows whose
        # reference agrees with the gyro) leave the offset free: the fit ran it to 1e13 ms and printed that.
        rate = float(np.degrees(np.max(np.linalg.norm(moves.omega, axis=1))))
        std = 1.0 / np.sqrt(info.min()) if info.min() > 0 else np.inf
        fixed = f"only to {1000 * std:.3g} ms" if std <= 1.0 else "not even to 1 s"
        raise CalibrationError(f"move samples: their {len(moves)} rows turn too little (at most {rate:.2g} deg/s) "
                               f"to fix the sample-time offset: {fixed}, {1000 * OFFSET_STD_S:g} ms needed")
    n_params = N_FIXED + groups
    E = tangent_basis(v0) * norm

    def unpack(p):
        w = v0 + E @ p[12:14]
        delta = np.zeros(len(Y))
        delta[n:] = p[N_FIXED:][label]
        return p[0:3], p[3:12].reshape(3, 3), norm * w / np.linalg.norm(w), w, delta

    def inputs(v, delta):
        x = np.einsum("kji,j->ki", RR, v)
        return x, x + C + delta[:, None] * np.cross(W, x)

    def residuals(p):
        B, H, v, _, delta = unpack(p)
        return ((Y - inputs(v, delta)[1] @ np.linalg.inv(H).T - B) / S).ravel()

    def jacobian(p):
        B, H, v, w, delta = unpack(p)
        K = np.linalg.inv(H)
        x, u = inputs(v, delta)
        J = np.zeros((len(Y), 3, n_params))
        J[:, :, 0:3] = -np.eye(3)
        J[:, :, 3:12] = np.einsum("ca,kb->kcab", K, u @ K.T).reshape(len(Y), 3, 9)
        wn = np.linalg.norm(w)
        dv = norm * (np.eye(3) - np.outer(w, w) / wn**2) / wn @ E                  # (3, 2)
        dx = np.einsum("kji,jd->kid", RR, dv)                                       # d x / d tilt
        du = dx + delta[:, None, None] * np.cross(W[:, :, None], dx, axis=1)
        J[:, :, 12:14] = -np.einsum("ca,kad->kcd", K, du)
        J[np.arange(n, len(Y)), :, N_FIXED + label] = -np.cross(W[n:], x[n:]) @ K.T
        return (J / S[:, :, None]).reshape(3 * len(Y), n_params)

    p0 = np.concatenate([hold_fit.B, hold_fit.H.ravel(), np.zeros(2 + groups)])
    sol = least_squares(residuals, p0, jac=jacobian, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    B, H, v, _, _ = unpack(sol.x)
    offsets = sol.x[N_FIXED:]
    if not (np.isfinite(sol.x).all() and sol.success):
        raise CalibrationError(f"move samples: the fit did not converge ({sol.message})")
    if groups and np.max(np.abs(offsets)) > MAX_OFFSET_S:
        worst = float(offsets[np.argmax(np.abs(offsets))])
        away = f"{1000 * worst:.1f} ms" if abs(worst) <= 1.0 else "more than 1 s"      # beyond that: no timing
        raise CalibrationError(f"move samples: a move fits only {away} away from its time stamps "
                               "(beyond any sample clock's offset): the moves' reference does not describe them")
    dof = 3 * len(Y) - n_params
    chi2 = float(2 * sol.cost / dof)
    out = TriadCalibration(B=B, H=H, method=hold_fit.method, iterations=hold_fit.iterations + int(sol.nfev),
                           converged=True, warnings=list(hold_fit.warnings))
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * max(chi2, 1.0)
    except np.linalg.LinAlgError:
        cov = None
    if cov is not None and np.all(np.diag(cov) >= 0):
        out.B_cov, out.H_cov = cov[0:3, 0:3], cov[3:12, 3:12]
        out.B_std = np.sqrt(np.diag(out.B_cov))
        out.H_std = np.sqrt(np.diag(out.H_cov)).reshape(3, 3)
        out.extra["v_std_deg"] = float(np.degrees(np.sqrt(np.trace(cov[12:14, 12:14]) / 2)))
        if groups:
            out.extra["time_offset_std_s"] = float(np.median(np.sqrt(np.diag(cov)[N_FIXED:])))
    if np.linalg.det(H) < 0:
        out.H, v = -H, -v
    misfit = out.apply(y_means) - np.einsum("kji,j->ki", R, v)
    out.residual_rms = float(np.sqrt(np.mean(np.sum(misfit**2, axis=1))))
    out.extra.update({k: val for k, val in hold_fit.extra.items() if k not in out.extra})
    out.extra.update({"reference_world": v.tolist(), "reduced_chi2": chi2, "move_samples": int(len(moves)),
                      "time_offset_s": float(np.median(offsets)) if groups else 0.0,
                      "time_offset_range_s": [float(offsets.min()), float(offsets.max())] if groups else [0.0, 0.0],
                      "hold_only": {"B": hold_fit.B.tolist(), "H": hold_fit.H.tolist()},
                      "_move_residuals": sol.fun.reshape(-1, 3)[len(y_means):] * moves.sigma})
    return out
