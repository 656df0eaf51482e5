"""An accelerometer turned slowly and never held still: `|H (y - B)| = g` fitted over its quasi-static samples.

imu_tk's method (`turntable_free`) needs still poses. A record turned slowly by hand without ever being set down
has none, or a few, but the norm of the specific force is gravity's wherever the hand does not accelerate the unit:
Frosio, Pedersini and Borghese ("Autocalibration of MEMS accelerometers", IEEE Trans. Instrum. Meas. 58(6), 2009)
calibrate on such quasi-static samples. Here:

* Still poses. A static interval imu_tk's detector found is still when its mean does not wander: its variance
  about its mean is at most STILL_DRIFT times the mean variance of its own QUIET_WINDOW_S stretches (white or
  filtered noise: 1; a hand-held stretch that turns slowly: its whole variance grows with its length). The record
  is fitted from its quasi-static samples where fewer than MIN_INTERVALS of its intervals are still, or where its
  still poses leave H undetermined (`told_rel`).
* Quasi-static samples. A sample's motion is the variance norm of the specific force over the QUIET_WINDOW_S
  centred on it (`static_detect.moving_variance_norm`: a turn, a jerk and noise all raise it). The quietest share
  of the record is fitted, the share (SHARES) chosen as imu_tk chooses its threshold by a criterion of the fit: here
  the one whose B and diagonal of H are told best (a larger share sees more of the sphere, a smaller one less of the
  hand's acceleration; the deviation weighs one against the other).
* Fit: H upper triangular (imu_tk's convention: the accelerometer's frame is the one H defines), B, by least squares
  over every sample (`turntable_free.fit_accel_upper`), started from the algebraic ellipsoid.
* Uncertainty. What the hand adds to |f| lasts for as long as a gesture: the residuals are not independent, and
  `s^2 (J^T J)^-1` of independent samples states a deviation many times too small. The covariance is the
  delete-a-group jackknife over BLOCKS blocks of consecutive samples (the time blocks as clusters, as in the
  cluster-robust variance of Liang and Zeger, Biometrika 73, 1986; `mag_alone._correlation_factor` reads the same
  for a magnetometer), `(G - 1) / G sum_b (d_b - mean d)(d_b - mean d)^T` with d_b the one-step change of the
  parameters without block b, widened by Student's t on G - 1 degrees of freedom. The centripetal acceleration of
  a turn about a wrist LEVER_M from the sensor, `|omega|^2 r`, is not zero on average and shifts the offset: its
  size at the fitted samples' turn rate is added to B's covariance.
  A fit told worse than TOLD_REL (its offset relative to g, or its scale) is refused, naming how much of the sphere
  the samples cover.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import stdtrit

from rig.calibration.recordings.mag_alone import coverage, directions_text
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.numerics.static_detect import moving_variance_norm
from rig.calibration.recordings.turntable_free import MIN_INTERVALS, fit_accel_upper
from rig.errors import CalibrationError

QUIET_WINDOW_S = 0.25     # a hand's gesture shows within it; a 100 Hz record's 25 samples
MIN_WINDOW = 5
STILL_DRIFT = 3.0         # a still pose's variance over its short stretches' (real poses: 1.0-1.5 in the five
# recordings of tests/data with poses; a hand that turns the unit slowly: 3-21)
SHARES = (0.25, 0.5, 0.75, 1.0)
BLOCKS = 20
MIN_SAMPLES = 200
MAX_SAMPLES = 20_000      # every k-th sample beyond this: the sphere is as well covered, the fit faster
RUN_SAMPLES = 25          # consecutive fitted samples averaged for the ellipsoid that starts the fit
TOLD_REL = 0.05           # an offset (of g) or scale known worse than this is not calibrated: a MEMS accelerometer's
# datasheet gives both to a few per cent (the gyro's HAND_TOLD_REL, `sampling`)
OUTSIDE_ONE_SIGMA = 0.31731050786291415
LEVER_M = 0.15


@dataclass
class QuasiStaticFit:
    """The calibration and the rows it was fitted on (indices into the record)."""

    calibration: TriadCalibration
    rows: np.ndarray


def window_rows(t: np.ndarray, seconds: float = QUIET_WINDOW_S) -> int:
    """An odd number of samples spanning `seconds` at the median sample rate (at least MIN_WINDOW)."""
    dt = float(np.median(np.diff(t)))
    n = max(int(round(seconds / dt)), MIN_WINDOW) if dt > 0 else MIN_WINDOW
    return n if n % 2 else n + 1


def drift_ratio(x: np.ndarray, win: int) -> float:
    """The variance norm of x (n, 3) about its mean over the mean variance norm of its stretches of `win` rows."""
    m = len(x) // win
    if m < 2:
        return 1.0
    short = np.linalg.norm(x[:m * win].reshape(m, win, 3).var(axis=1, ddof=1).mean(axis=0))
    whole = np.linalg.norm(x.var(axis=0, ddof=1))
    return float(whole / short) if short > 0 else (1.0 if whole == 0 else np.inf)


def still_intervals(t: np.ndarray, y: np.ndarray, intervals: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The static intervals whose mean does not wander (`drift_ratio` at most STILL_DRIFT)."""
    win = window_rows(t)
    return [(a, b) for a, b in intervals if drift_ratio(y[a:b + 1], win) <= STILL_DRIFT]


def motion(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Each sample's motion: the variance norm of the specific force over the QUIET_WINDOW_S centred on it (inf
    within half a window of the ends)."""
    return np.nan_to_num(moving_variance_norm(y, window_rows(t)), nan=np.inf)


def quasi_static_accel(t: np.ndarray, y: np.ndarray, gravity: float, *, still: int = 0) -> QuasiStaticFit:
    """The accelerometer of a record with fewer than MIN_INTERVALS still poses (`still` of them), from its
    quasi-static samples (see the module); CalibrationError where none of the shares is told to TOLD_REL."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    moving = motion(t, y)
    finite = np.isfinite(moving)
    if finite.sum() < MIN_SAMPLES:
        raise CalibrationError(f"{finite.sum()} samples away from the record's ends; the norm of quasi-static samples "
                               f"needs at least {MIN_SAMPLES}")
    order = np.argsort(moving[finite], kind="stable")
    candidates, failures = [], []
    for share in SHARES:
        keep = np.sort(np.flatnonzero(finite)[order[:int(share * finite.sum())]])
        try:
            candidates.append(_fit_share(t, y, keep, gravity, share))
        except (CalibrationError, np.linalg.LinAlgError) as exc:
            failures.append(str(exc))
    told = [c for c in candidates if c["told"] <= TOLD_REL]
    if not told:
        if not candidates:
            raise CalibrationError(f"its quasi-static samples do not bound an ellipsoid ({failures[0]})")
        best = min(candidates, key=lambda c: c["score"])
        raise CalibrationError(f"its quasi-static samples leave the accelerometer undetermined: {best['worst']} is "
                               f"known to only {100 * best['told']:.2g} % (at most {100 * TOLD_REL:g} %); "
                               f"{directions_text(best['directions'], 'accelerometer')}: turn the unit slowly through "
                               "more of the sphere, or hold it still in more poses")
    best = min(told, key=lambda c: c["score"])
    cal = TriadCalibration(
        B=best["B"], H=best["H"], method="quasi-static-accel (the norm over the samples where the unit turns slowly; "
                                         "imu_tk convention: upper-triangular H)",
        residual_rms=best["rms"], iterations=best["iterations"], B_std=best["B_std"], H_std=best["H_std"],
        B_cov=best["B_cov"], H_cov=best["H_cov"],
        warnings=[quasi_static_warning(best, still)],
        extra={"quasi_static": {"samples": int(len(best["rows"])), "share": best["share"],
                                "window_s": QUIET_WINDOW_S, "blocks": best["blocks"],
                                "correlation_factor": best["factor"], "student_factor": best["student"],
                                "still_poses": int(still), "sphere_coverage": round(best["coverage"], 3)},
               "uncertainty": {"from": "blocks of consecutive samples", "blocks": best["blocks"]}})
    return QuasiStaticFit(cal, best["rows"])


def told_relative(cal: TriadCalibration, gravity: float) -> float:
    """The largest of an accelerometer's offset deviations relative to g and its scales' relative deviations (0
    where it states none)."""
    if cal.B_std is None or cal.H_std is None:
        return 0.0
    scale = np.abs(np.diag(cal.H))
    return float(np.max(np.r_[np.asarray(cal.B_std) * scale / gravity, np.diag(cal.H_std) / scale]))


def quasi_static_warning(fit: dict, still: int) -> str:
    return (f"{still} still poses ({MIN_INTERVALS} are needed): fitted instead to the norm of its "
            f"{len(fit['rows'])} quasi-static samples (the {100 * fit['share']:.0f} % of the record whose specific "
            f"force changes least over {QUIET_WINDOW_S:g} s; their directions cover {100 * fit['coverage']:.0f} % of "
            f"the sphere). What the hand's acceleration adds to |a| (RMS {fit['rms']:.2g} m/s^2 about g) lasts for a "
            f"gesture, so B_std and H_std are taken from {fit['blocks']} blocks of consecutive samples: "
            f"{np.sqrt(fit['factor']):.2g} times what independent samples would state")


def _fit_share(t: np.ndarray, y: np.ndarray, keep: np.ndarray, gravity: float, share: float) -> dict:
    rows = keep[::max(1, len(keep) // MAX_SAMPLES)]
    if len(rows) < MIN_SAMPLES:
        raise CalibrationError(f"{len(rows)} quasi-static samples; the norm fit needs {MIN_SAMPLES}")
    samples = y[rows]
    runs = np.array_split(np.arange(len(rows)), max(len(rows) // RUN_SAMPLES, 1))
    B, H, cost = fit_accel_upper([samples[r] for r in runs], gravity, per_sample=True)
    if not np.linalg.det(H) > 0:
        raise CalibrationError(f"the fit over the quietest {100 * share:.0f} % came out mirrored")
    cov, factor, blocks, student = block_covariance(samples, rows, B, H, gravity)
    B_cov, H_cov = cov[:3, :3], cov[3:, 3:]
    turn = turn_rate(t, (y - B) @ H.T)
    swing = LEVER_M * float(np.mean(turn[rows] ** 2)) / np.sqrt(3.0)      # per axis, m/s^2
    H_inv = np.linalg.inv(H)
    B_cov = B_cov + swing ** 2 * H_inv @ H_inv.T
    B_std = np.sqrt(np.clip(np.diag(B_cov), 0, None))
    H_std = np.sqrt(np.clip(np.diag(H_cov), 0, None)).reshape(3, 3)
    scale = np.abs(np.diag(H))
    relative = np.r_[B_std * scale / gravity, np.diag(H_std) / scale]
    worst = int(np.argmax(relative))
    v = (samples - B) @ H.T
    norm = np.linalg.norm(v, axis=1)
    directions = v / norm[:, None]
    return {"B": B, "H": H, "B_cov": B_cov, "H_cov": H_cov, "B_std": B_std, "H_std": H_std, "rows": rows,
            "share": share, "factor": factor, "blocks": blocks, "student": student, "iterations": 0,
            "swing": swing, "rms": float(np.sqrt(np.mean((norm - gravity) ** 2))), "coverage": coverage(directions),
            "directions": directions, "told": float(relative.max()),
            "score": float(np.sqrt(np.mean(relative ** 2))),
            "worst": f"B[{worst}]" if worst < 3 else f"the scale H[{worst - 3}, {worst - 3}]"}


def turn_rate(t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """How fast gravity's direction turns in the sensor (rad/s, the rate's part across it), from the calibrated
    specific force f (n, 3): the change of its direction across the QUIET_WINDOW_S centred on each sample (inf
    within half a window of the ends)."""
    h = window_rows(t) // 2
    u = f / np.linalg.norm(f, axis=1, keepdims=True)
    out = np.full(len(t), np.inf)
    if len(t) > 2 * h:
        out[h:-h] = np.linalg.norm(u[2 * h:] - u[:-2 * h], axis=1) / (t[2 * h:] - t[:-2 * h])
    return out


def block_covariance(samples: np.ndarray, rows: np.ndarray, B: np.ndarray, H: np.ndarray, gravity: float
                     ) -> tuple[np.ndarray, float, int, float]:
    """The covariance (12, 12: B, then row-major vec(H), zero below the diagonal) of the norm fit over `samples`
    (at record `rows`), clustered over BLOCKS blocks of consecutive rows (see the module); the ratio of its
    diagonal to that of independent samples (averaged), the blocks used and the Student factor applied."""
    upper = np.triu_indices(3)
    d = samples - B
    v = d @ H.T
    u = v / np.linalg.norm(v, axis=1, keepdims=True)
    r = np.linalg.norm(v, axis=1) - gravity
    J = np.hstack([-u @ H, u[:, upper[0]] * d[:, upper[1]]])
    scale = np.linalg.norm(J, axis=0)
    Js = J / scale
    A_inv = np.linalg.pinv(Js.T @ Js)
    span = rows[-1] - rows[0] + 1
    label = ((rows - rows[0]) * BLOCKS) // span
    present = np.unique(label)
    G = len(present)
    student = float(stdtrit(G - 1, 1.0 - OUTSIDE_ONE_SIGMA / 2)) ** 2 if G > 1 else np.inf
    A = Js.T @ Js
    d = np.array([np.linalg.solve(A - Js[label == b].T @ Js[label == b], Js[label == b].T @ r[label == b])
                  for b in present])
    d -= d.mean(axis=0)
    clustered = d.T @ d * (G - 1) / G * student
    plain = A_inv * float(r @ r) / max(len(r) - 9, 1)
    factor = float(np.mean(np.diag(clustered) / np.where(np.diag(plain) > 0, np.diag(plain), np.inf)))
    cov = clustered / np.outer(scale, scale)
    full = np.zeros((12, 12))
    idx = np.r_[0:3, 3 + 3 * upper[0] + upper[1]]
    full[np.ix_(idx, idx)] = cov
    return full, factor, G, student
