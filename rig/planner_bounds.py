"""The predicted accuracy of a session plan: Cramer-Rao bounds of every sensor's B and H from the plan alone.

Accelerometer and magnetometer: `rig.calibration.turntable.bounds.cramer_rao` on the planned holds, each hold mean with
the white noise of its samples (sigma / sqrt(samples in the hold)). The sensor is taken in its own units
(H = I, B = 0): the relative error of H and the error of B in units do not depend on the count scale.

Gyroscope: the moves give H, the holds give B. A move from hold j to hold j+1 is `phi_k = H (S_k - B T_k)`
(rotation vector of the known rotation R_j^T R_j+1, S_k the integrated raw rate over the move's T_k seconds;
the first-order picture of the UKF's fit of the integrated rotation, `rig.calibration.turntable.gyro`); white rate noise
puts `sigma^2 dt T_k` on each axis of S_k (angle random walk), and the reference adds the angle noise of its
two hold orientations and an error in proportion to its angle (MOVE_RELATIVE_SD). The holds' gyro means measure B with
sigma^2 / samples. The Fisher information of (vec H, B) is summed over moves and holds and inverted, as in bounds.py.

Accelerometer and magnetometer samples of the moves (`rig.pipeline.move_rows`): every
sample of a move is one more reading at the orientation the table has at that instant, with the sensor's
per-sample noise; `move_rotations` samples the planned moves (both axes' trapezoids from the same start, then
the still time until the hold begins) and `vector_bound` adds them to the holds. The pipeline also fits the
samples' time offset and takes the lever arm's specific force from its own fit: on the default session the
bound with both as free parameters is the same to three digits (offset known to 20 us, arm to 0.05 mm), so
they are left out here. The pipeline leaves out the rows whose reference disagrees with the gyro (the
corners of the rate profile between two encoder polls): MOVE_ROWS_USED of them on the simulated rig.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.turntable.bounds import cramer_rao
from rig.errors import CalibrationError
from rig.rotations import TableGeometry, rotvec_from_matrix
from rig.trapezoid import trapezoid

# Angle noise of one hold's reference orientation (rad): the encoder mean of a hold against the table's true
# attitude (a 0.001 deg encoder step, the servo's dither within its tolerance).
REFERENCE_ANGLE_SD_RAD = float(np.radians(0.002))
# Rotation error of a move in proportion to its angle, beyond the white rate noise: what the first-order model
# misses (the reading of the samples, point or mean, and the reference's interpolation between polls grow with
# the turn). Fitted on the simulated rig with benchmarks/bench_planner.py (achieved over predicted gyro H error
# across plans of 9-36 orientations); sparse plans with long moves are the ones it matters for.
MOVE_RELATIVE_SD = 1.5e-4
# Seconds of still table a move's integration carries on each side of the motion (the pipeline's trim margin).
MOVE_MARGIN_S = 0.05
# Share of a move's accelerometer/magnetometer rows the pipeline keeps (rig.pipeline.move_rows: the others'
# reference disagrees with the gyro): 0.91 on the default simulated session (2374 of 2604 rows).
MOVE_ROWS_USED = 0.9
# The planner takes every MOVE_DECIMATION-th sample of a planned move, weighted as that many: the orientation
# changes little between them (at 120 deg/s, 6 deg in 5 samples), the bound by less than 0.5 %, planning 3x faster.
MOVE_DECIMATION = 5


def vector_bound(R: np.ndarray, reference_world: np.ndarray, sigma: float, samples: np.ndarray,
                 move_R: np.ndarray | None = None, move_weight: float = 1.0) -> tuple[float, float]:
    """(H relative RMS, B RMS in units) of an accelerometer/magnetometer from holds at R (n, 3, 3) with `samples`
    (n,) samples of white noise `sigma` (units) each, and at the move orientations `move_R` (m, 3, 3) if given,
    each standing for `move_weight` samples (a decimated path). Raises CalibrationError for an unobservable plan."""
    s = sigma / np.sqrt(np.asarray(samples, dtype=float))
    if move_R is not None and len(move_R):
        R = np.concatenate([R, move_R])
        s = np.concatenate([s, np.full(len(move_R), sigma / np.sqrt(MOVE_ROWS_USED * move_weight))])
    cr = cramer_rao(R, np.eye(3), np.zeros(3), reference_world, s)
    return cr.H_rel_rms, cr.B_rms


def _travelled(distance: np.ndarray, speed: float, accel: float, t: np.ndarray) -> np.ndarray:
    """Angle travelled (deg, signed) at times t (row-wise) of rest-to-rest trapezoids over `distance` (rows)."""
    d = np.abs(distance)
    peak = np.minimum(speed, np.sqrt(d * accel))
    t1 = peak / accel
    safe = np.where(peak > 0, peak, 1.0)
    T = 2 * t1 + np.where(peak > 0, (d - peak * t1) / safe, 0.0)
    p = np.where(t < t1, 0.5 * accel * t**2, np.where(t < T - t1, 0.5 * accel * t1**2 + peak * (t - t1),
                                                        np.where(t < T, d - 0.5 * accel * (T - t).clip(0)**2, d)))
    return np.sign(distance) * p


def move_rotations(outer_deg: np.ndarray, inner_deg: np.ndarray, geometry: TableGeometry, speed_dps: float,
                   accel_dps2: float, rate_hz: float, still_s: float) -> np.ndarray:
    """Fixture -> world orientations (m, 3, 3) at every sample (`rate_hz`) of the moves between consecutive
    holds at the table angles given (n,): both axes start together on their own trapezoids (rig.trapezoid,
    equal acceleration and deceleration), then `still_s` at the target before the hold begins."""
    outer_deg, inner_deg = np.asarray(outer_deg, dtype=float), np.asarray(inner_deg, dtype=float)
    if len(outer_deg) < 2:
        return np.zeros((0, 3, 3))
    da, db = np.diff(outer_deg), np.diff(inner_deg)
    seconds = [max(trapezoid(a, speed_dps, accel_dps2).duration, trapezoid(b, speed_dps, accel_dps2).duration)
               for a, b in zip(da, db)]
    counts = np.array([len(np.arange(0.0, s + still_s, 1.0 / rate_hz)) for s in seconds])
    move = np.repeat(np.arange(len(da)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / rate_hz
    return geometry.rotation(outer_deg[move] + _travelled(da[move], speed_dps, accel_dps2, t),
                             inner_deg[move] + _travelled(db[move], speed_dps, accel_dps2, t))


def gyro_bound(R: np.ndarray, move_s: np.ndarray, sigma: float, rate_hz: float,
               hold_samples: np.ndarray) -> tuple[float, float]:
    """(H relative RMS, B RMS in rad/s) of a gyroscope from the moves between consecutive holds at R (n, 3, 3),
    taking `move_s` (n-1,) seconds each, white rate noise `sigma` (rad/s per sample at `rate_hz`), and the holds'
    `hold_samples` (n,) for the bias."""
    R = np.asarray(R, dtype=float)
    phi = rotvec_from_matrix(np.einsum("kji,kjl->kil", R[:-1], R[1:]))
    T = np.asarray(move_s, dtype=float) + 2 * MOVE_MARGIN_S
    dt = 1.0 / rate_hz
    F = np.zeros((12, 12))
    for p, t in zip(phi, T):
        J = np.zeros((3, 12))
        J[:, 0:9] = np.kron(np.eye(3), p[None, :])          # d(H S)/d vec(H), row-major, at H = I: S = phi
        J[:, 9:12] = -t * np.eye(3)                          # d(-H B T)/dB
        var = sigma**2 * dt * t + 2 * REFERENCE_ANGLE_SD_RAD**2 + (MOVE_RELATIVE_SD * np.linalg.norm(p))**2
        F += J.T @ J / var
    F[9:12, 9:12] += np.eye(3) * float(np.sum(hold_samples)) / sigma**2
    d = np.sqrt(np.diag(F))
    if np.any(d == 0):
        raise CalibrationError("gyro: the moves do not determine H")
    C = F / np.outer(d, d)
    w = np.linalg.eigvalsh(C)
    if w[0] < 1e-12 * w[-1]:
        raise CalibrationError("gyro: the moves do not turn about three independent axes")
    cov = np.linalg.solve(C, np.eye(12)) / np.outer(d, d)
    return float(np.sqrt(np.trace(cov[:9, :9])) / np.sqrt(3.0)), float(np.sqrt(np.trace(cov[9:, 9:])))
