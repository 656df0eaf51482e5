"""Peer filters from the `ahrs` package (Madgwick, Mahony, EKF) on the same calibrated data.

Conventions checked against ahrs 0.4.0 (its source, and the frame-alignment test in tests/attitude):
* all three return scalar-first quaternions that rotate fixture vectors into their navigation frame;
  each has its own navigation frame (Madgwick starts from an NED e-compass, Mahony and our EKF call
  ENU), which the validation's constant alignment removes like ours.
* ahrs' EKF in its ENU frame takes the gravity reference (0, 0, -1): it expects the accelerometer to
  read gravity, not specific force, so it is given -a.
* they need every sensor on every row: rows without a magnetometer sample get the linear
  interpolation in time (the magnetometer runs at half the accelerometer's rate on the sim rig).
  That reads the next sample (a lookahead the UKF does not get); measured over ten simulated seeds it
  is worth nothing to the EKF (filling causally, the last sample turned forward with the gyro, gives
  a mean total RMS of 0.0535 deg against 0.0536 deg), so the fill is kept.
"""

from __future__ import annotations

import numpy as np

from rig.attitude.noise import SensorNoise

PEERS = ("madgwick", "mahony", "ekf", "ekf-still", "ekf-defaults")


def fill_rows(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x).all(axis=1)
    if ok.all():
        return x
    if ok.sum() < 2:
        raise ValueError("fewer than two finite samples: cannot fill the missing rows")
    return np.column_stack([np.interp(t, t[ok], x[ok, i]) for i in range(3)])


def run_peer(name: str, t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, mag: np.ndarray, *,
             noise: SensorNoise, gravity: float, field_uT: float, dip_deg: float, q0_enu: np.ndarray,
             still: np.ndarray | None = None) -> np.ndarray:
    """Quaternions (n, 4), fixture -> the peer's navigation frame.

    still: (n,) steps the UKF took as still; 'ekf-still' gets a zero rate there (the ahrs EKF with the
    UKF's zero-rate detection as a preprocessing step: a stronger peer than the plain 'ekf').
    """
    from ahrs.filters import EKF, Madgwick, Mahony

    gyro, accel, mag = (fill_rows(t, np.asarray(x, dtype=float)) for x in (gyro, accel, mag))
    if name == "ekf-still" and still is not None:
        gyro = np.where(np.asarray(still, bool)[:, None], 0.0, gyro)
    freq = 1.0 / float(np.median(np.diff(t)))
    if name == "madgwick":
        make = lambda g, a, m: Madgwick(gyr=g, acc=a, mag=m, frequency=freq)  # noqa: E731
        step = "updateMARG"
    elif name == "mahony":
        make = lambda g, a, m: Mahony(gyr=g, acc=a, mag=m, frequency=freq, q0=np.asarray(q0_enu, dtype=float))  # noqa: E731
        step = "updateMARG"
    elif name in ("ekf", "ekf-still", "ekf-defaults"):
        # 'ekf': variances of the unit vectors it compares from the same noise the UKF is given;
        # 'ekf-defaults': the package's own noise settings, as a user gets it out of the box
        kw = {} if name == "ekf-defaults" else {"noises": [noise.gyro_rad_s ** 2, (noise.accel_mps2 / gravity) ** 2,
                                                           (noise.mag_uT / field_uT) ** 2]}
        make = lambda g, a, m: EKF(gyr=g, acc=a, mag=m, frequency=freq, frame="ENU", magnetic_ref=float(dip_deg),  # noqa: E731
                                   q0=np.asarray(q0_enu, dtype=float), **kw)
        accel, step = -accel, "update"
    else:
        raise ValueError(f"unknown peer filter {name!r}; choose from {PEERS}")
    if not irregular(t):
        return make(gyro, accel, mag).Q
    return per_sample(make, step, t, gyro, accel, mag)


def irregular(t: np.ndarray, tolerance: float = 0.01) -> bool:
    """Rows not on one fixed period (multi-rate rows at the union of the sensors' sample times, jitter, gaps)."""
    dt = np.diff(t)
    return bool(dt.max() - dt.min() > tolerance * float(np.median(dt)))


def per_sample(make, step: str, t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, mag: np.ndarray) -> np.ndarray:
    """The peer's own update, row by row with each row's own interval.

    The ahrs batch mode assumes one fixed period; on irregular rows it would integrate the gyro over the
    wrong intervals (14 deg errors on rows at the union of 200, 100 and 75 Hz sensors), which says
    nothing about the filter. Same start and same update as the batch mode, only `dt` per row."""
    f = make(gyro[:1], accel[:1], mag[:1])
    Q = np.empty((len(t), 4))
    Q[0] = f.Q[0]
    update = getattr(f, step)
    for k in range(1, len(t)):
        Q[k] = update(Q[k - 1], gyro[k], accel[k], mag[k], dt=float(t[k] - t[k - 1]))
    return Q
