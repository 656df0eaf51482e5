"""Quaternion-based unscented Kalman filter for attitude (Yuan et al., Sensors 2015), singularity-free.

The paper (reconstructed here; its text was not available, equation numbers as in the project brief):
state the unit quaternion, process model the gyro quaternion update (eqs. 7-8, 13) with process noise
from the gyro noise (eq. 16), measurement roll, pitch and heading from the accelerometer and the
tilt-compensated magnetometer (eqs. 2-5, 14) with noise propagated from theirs (eqs. 17-22), and the
scaled unscented transform (eqs. 23-28).

Where this departs, and why:
* Quaternion-aware UT: sigma points are error rotation vectors around the mean quaternion
  (`q_i = q Exp(d_i)`), so every sigma point stays a unit quaternion and the mean is the mean quaternion
  (adding and averaging quaternion components, as a plain UKF would, leaves the unit sphere).
* The measurement of eq. 14 (Euler roll/pitch/heading) is singular at pitch +-90 deg, which a tumble
  table passes through. We measure instead the unit gravity direction in the body frame, and from the
  magnetometer either (default, 'vector') the unit field direction in the body frame, compared with the
  reference field of the navigation frame in a second, sequential update; or ('heading', the paper's
  split) the heading alone: the angle about the measured gravity direction from the measured horizontal
  field to the predicted one (atan2, wrapped), in one joint 4-D update with gravity, so the magnetometer
  cannot move roll and pitch. Every form is defined at every attitude (the heading needs a field that is
  not vertical). On the simulated rig 'vector' is a little more accurate (the field carries tilt
  information too); 'heading' keeps a disturbed field, when it slips through the gates, out of the tilt.
* Indoor disturbances: magnetometer samples whose |m| or dip angle depart from the reference are not
  used (counted in the result); accelerometer samples whose |a| departs from G likewise.

* Zero-rate steps (`measurements.StillDetector`, on by default): where the gyro shows only noise the
  fixture is taken as still and the attitude kept, so a hold's gravity and field samples average down
  instead of being forgotten within ~0.3 s under the integrated gyro noise.

Against an extended Kalman filter: at the covariances reached on a calibrated unit (~0.02 deg) the
measurement functions are linear over the sigma points, so this filter gives the estimate of the
first-order filter on the same models (to ~1e-9, the forward pass of `smoother.py`; tests). Without the
zero-rate steps the `ahrs` EKF given the same noise ties it over ten seeds; with them the UKF is ahead
of every `ahrs` peer, also of the EKF fed the same zero-rate steps (benchmarks/bench_attitude.py).
What the data allow beyond a causal filter is shown by the RTS smoother on the same models (`smoother.py`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints

from rig.attitude import kernel
from rig.attitude.measurements import Gates, Prepared, StillDetector, dip_of, field_in_navigation, prepare, tilt_only, triad
from rig.attitude.noise import SensorNoise
from rig.rotations import quat_from_matrix

STATE_DIM = 3   # the error rotation vector
MAG_MEASUREMENTS = ("vector", "heading")


@dataclass(frozen=True)
class UKFSettings:
    alpha: float = 1.0          # scaled UT (Merwe): spread of the sigma points
    beta: float = 2.0
    kappa: float = 0.0
    gates: Gates = field(default_factory=Gates)
    init_s: float = 0.5         # still interval at the start used for the initial attitude and noise
    initial_std_deg: float | None = None   # None: from the still interval (noise / sqrt(samples))
    min_initial_std_deg: float = 0.02
    # Floors under the noise estimated from the still interval: quantised, nearly noiseless sensors
    # would otherwise make the filter overconfident.
    noise_floor: SensorNoise = field(default_factory=lambda: SensorNoise(2e-4, 2e-3, 0.05))
    use_mag: bool = True
    # 'vector': the field direction in the body frame (3-D, informs tilt too), a sequential update after
    # gravity's; 'heading': the paper's use, the magnetometer informs heading only (joint 4-D update).
    mag_measurement: str = "vector"
    # zero-rate steps where the gyro shows only noise (None: integrate the gyro everywhere, the paper's)
    still: StillDetector | None = field(default_factory=StillDetector)

    def __post_init__(self) -> None:
        if self.mag_measurement not in MAG_MEASUREMENTS:
            raise ValueError(f"mag_measurement must be one of {MAG_MEASUREMENTS}, got {self.mag_measurement!r}")


@dataclass
class AttitudeEstimate:
    t: np.ndarray                 # (n,)
    q: np.ndarray                 # (n, 4) fixture -> navigation (magnetic ENU), scalar first, w >= 0
    std_deg: np.ndarray           # (n, 3) filter standard deviation of the error rotation, deg
    noise: SensorNoise
    dip_deg: float                # reference dip used for the magnetometer gate
    field_uT: float               # reference |m| used for the magnetometer gate
    counts: dict                  # samples used / rejected per sensor
    still: np.ndarray | None = None   # (n,) bool: steps the filter took as still (zero rate)

    def summary(self) -> dict:
        return {"noise": asdict(self.noise), "dip_deg": self.dip_deg, "field_uT": self.field_uT, **self.counts}


def sigma_weights(settings: UKFSettings, n: int = STATE_DIM) -> tuple[float, float, float, float]:
    """(c, Wm0, Wc0, Wi) of the scaled unscented transform (eqs. 23-28): filterpy's MerweScaledSigmaPoints
    weights, and the sigma points' spread c = sqrt(n + lambda), lambda = alpha^2 (n + kappa) - n."""
    w = MerweScaledSigmaPoints(n, alpha=settings.alpha, beta=settings.beta, kappa=settings.kappa)
    lam = settings.alpha ** 2 * (n + settings.kappa) - n
    return math.sqrt(n + lam), float(w.Wm[0]), float(w.Wc[0]), float(w.Wm[1])


def initial_rows(t: np.ndarray, init_s: float) -> np.ndarray:
    return np.flatnonzero(t <= t[0] + init_s)


def estimate_attitude(t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, mag: np.ndarray | None = None, *,
                      gravity: float = 9.80665, field_uT: float | None = None, noise: SensorNoise | None = None,
                      still_rows: np.ndarray | None = None, settings: UKFSettings | None = None) -> AttitudeEstimate:
    """Run the filter on calibrated signals (rad/s, m/s^2, uT; NaN rows where a sensor had no sample).

    still_rows: rows where the fixture was still (default: the first `init_s` seconds); they give the
    initial attitude, the reference dip and, unless `noise` is given, the sensor noise.
    field_uT: reference |m| for the disturbance gate (default: mean |m| over still_rows).
    """
    settings = settings or UKFSettings()
    setup = setup_filter(t, gyro, accel, mag, gravity=gravity, field_uT=field_uT, noise=noise,
                         still_rows=still_rows, settings=settings)
    quats, diag, n_acc, n_mag = _run(setup, settings)
    return finish(setup, np.array(quats), np.array(diag), n_acc, n_mag)


@dataclass
class FilterSetup:
    """The filter's inputs after initialisation: shared by the fast kernel and the filterpy reference."""

    t: np.ndarray
    prep: Prepared
    q0: np.ndarray
    noise: SensorNoise
    dip_rad: float
    field_uT: float
    P0: np.ndarray


def setup_filter(t, gyro, accel, mag, *, gravity: float, field_uT: float | None, noise: SensorNoise | None,
                 still_rows: np.ndarray | None, settings: UKFSettings) -> FilterSetup:
    """Initial attitude (TRIAD on the still rows), reference dip and |m|, noise, and the prepared steps."""
    t = np.asarray(t, dtype=float)
    accel = np.asarray(accel, dtype=float)
    mag = None if (mag is None or not settings.use_mag) else np.asarray(mag, dtype=float)
    rows = initial_rows(t, settings.init_s) if still_rows is None else np.asarray(still_rows)
    a0 = _mean_finite(accel[rows], "accelerometer")
    if noise is None:
        noise = SensorNoise.from_static(np.asarray(gyro, dtype=float)[rows], accel[rows],
                                        mag[rows] if mag is not None else None)
    noise = noise.floored(*(getattr(settings.noise_floor, f) for f in ("gyro_rad_s", "accel_mps2", "mag_uT")))
    if mag is not None:
        m0 = _mean_finite(mag[rows], "magnetometer")
        dip = float(dip_of(a0, m0))
        M = float(field_uT) if field_uT is not None else float(np.linalg.norm(m0))
        R0 = triad(a0, m0)
    else:
        dip, M, R0 = float("nan"), float("nan"), tilt_only(a0)
    prep = prepare(t, gyro, accel, mag, noise, gravity, M, dip, settings.gates, settings.still)
    P0 = initial_covariance(settings, R0, noise, gravity, prep, rows)
    return FilterSetup(t, prep, quat_from_matrix(R0), noise, dip, M, P0)


def finish(setup: FilterSetup, q: np.ndarray, diag: np.ndarray, n_acc: int, n_mag: int) -> AttitudeEstimate:
    prep = setup.prep
    q = np.where(q[:, :1] < 0, -q, q)
    counts = {"samples": int(len(setup.t)), "accel_updates": int(n_acc), "accel_rejected": prep.accel_rejected,
              "mag_samples": prep.mag_present, "mag_updates": int(n_mag), "mag_rejected_norm": prep.mag_rejected_norm,
              "mag_rejected_dip": prep.mag_rejected_dip,
              "still_steps": int(prep.still.sum())}
    return AttitudeEstimate(setup.t, q, np.degrees(np.sqrt(np.maximum(diag, 0.0))), setup.noise,
                            math.degrees(setup.dip_rad), setup.field_uT, counts, prep.still)


def initial_covariance(settings: UKFSettings, R0: np.ndarray, noise: SensorNoise, gravity: float, prep: Prepared,
                       rows: np.ndarray) -> np.ndarray:
    """Covariance of the initial error rotation (body frame).

    The initial attitude averages the still interval, so its tilt variance is the per-sample one over
    the accelerometer samples, its heading variance the per-sample heading one over the magnetometer
    samples. A loose P0 would let the first single sample pull the estimate away from that average.
    No magnetometer: the heading is unobservable and the filter's heading is, by definition, the one it
    starts with (the validation's frame alignment removes it), so it gets the tilt's variance. A wide
    prior there (90 deg was used) puts the sigma points ~150 deg apart about the vertical, and the
    unscented transform's nonlinearity then turned accelerometer updates in motion into 10-20 deg
    attitude errors.
    """
    floor = math.radians(settings.min_initial_std_deg) ** 2
    if settings.initial_std_deg is not None:
        return max(math.radians(settings.initial_std_deg) ** 2, floor) * np.eye(STATE_DIM)
    n_acc = max(int(prep.accel_ok[rows].sum()), 1)
    tilt = (noise.accel_mps2 / gravity) ** 2 / n_acc
    mag_rows = rows[prep.mag_ok[rows]]
    heading = float(np.mean(prep.heading_var[mag_rows])) / len(mag_rows) if len(mag_rows) else tilt
    nav = np.diag([max(tilt, floor), max(tilt, floor), max(heading, floor)])
    return R0.T @ nav @ R0


def _run(setup: FilterSetup, settings: UKFSettings):
    prep = setup.prep
    c, wm0, wc0, wi = sigma_weights(settings)
    P = setup.P0
    vector = settings.mag_measurement == "vector"
    mags, mag_var = (prep.field_dir, prep.field_var) if vector else (prep.north, prep.heading_var)
    ups = [tuple(u) if ok else None for u, ok in zip(prep.up.tolist(), prep.accel_ok.tolist())]
    mags = [tuple(m) if ok else None for m, ok in zip(mags.tolist(), prep.mag_ok.tolist())]
    steps = zip(prep.dq, prep.A, prep.q_var, ups, prep.up_var.tolist(), mags, mag_var.tolist())
    field_nav = field_in_navigation(setup.dip_rad) if vector else None
    if vector and not np.isfinite(setup.dip_rad):
        field_nav = (0.0, 1.0, 0.0)   # no magnetometer: never used
    P6 = tuple(float(P[i, j]) for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)))
    return kernel.run(tuple(float(v) for v in setup.q0), P6, steps, c, wm0, wc0, wi, field_nav)


def _mean_finite(x: np.ndarray, what: str) -> np.ndarray:
    ok = np.isfinite(x).all(axis=1)
    if not ok.any():
        raise ValueError(f"no finite {what} sample in the still interval used to initialise the filter")
    return x[ok].mean(axis=0)
