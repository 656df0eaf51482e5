"""Poses that are not still (effects.md `hold_not_still`, `vibration`): a hand or a soft mount disturbs each pose by
its own amount, which the twin measures pose by pose against the quiet poses' level and gives to its replicas; a
rotation where the gyro agrees, a vibration where the accelerometer shows more than the gyro's rotation gives."""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2

from fixtures.world.effects.noise import HoldNotStill, ShapedNoise
from fixtures.world.effects.vibration import Vibration
from procedures.twin.cause import Cause
from procedures.twin.draws import extension_level, level_dof
from procedures.twin.noise import pose_spreads, quiet_noise, quiet_poses, quiet_spread, sampled_rows
from procedures.twin.replay import Replay
from procedures.twin.vibration import Split, rate_across_gravity, split_by_gyro
from rig.calibration.recordings.recording import RecordingCalibration
from rig.session_data import SessionData

SHAKE_TAU_S = 0.05        # a hand's tremor (8-12 Hz) and a soft mount's ringing, as a correlation time
TILT_BAND_HZ = 2.0        # a hand's sway: below it gravity turns by enough for the accelerometer to see
VIBRATION_SIGMAS = 4.0    # the accelerometer's part no rotation gives, in its periodograms' deviations, to be named
VIBRATION_STREAM = 0x71B  # a vibration's draws, apart from every other cause's


def held_poses(session: SessionData, rec: RecordingCalibration, replay: Replay, floors: dict, spreads_off: set[str],
               rate: np.ndarray | None) -> list[Cause]:
    """The causes of poses whose spreads are out of their band (`spreads_off`: "gyro.spread", "accel.spread"): a
    rotation (`hold_not_still`), which a gyro present must read, and what the accelerometer shows beyond what the
    gyro's rate in the same poses gives (`vibration`, `procedures.twin.vibration`), each where it is so.

    The accelerometer's disturbance is vibration where its larger part is not the gyro's rotation and stands clear of
    the periodograms' own scatter (VIBRATION_SIGMAS); the rotation then takes only the share the gyro gives, beside
    the gyro's own disturbance where its poses' spreads differ beyond their sampling (`unequal_spreads`; they need
    not be out of their band as a family: on the Xsens recording they are not, and the gyro's part brought back 85
    statistics). Without a disturbed gyro, a vibration leaves no rotation: a clean gyro's quiet poses, chosen for
    their low spread, had made the others look disturbed by 0.06 deg/s.

    Both give the accelerometer the quiet poses' noise beneath, so its disturbance is split whether or not its own
    spreads were out: a hand's turn named from the gyro had taken a vibration the gyro never saw for its own, with a
    rotation's low-frequency wander, and pushed the norm scatter out.

    `rate` is the gyro's rate in rad/s where the recording says it (`procedures.twin.vibration.gyro_rate`); without it
    (a gyro in counts that could not be calibrated, or none) nothing contradicts the accelerometer, and its disturbance
    is the rotation it shows."""
    quiet = {s: quiet_spread(session, rec, s) for s in ("gyro", "accel") if s in replay.sensors}
    excess = {s: np.array([_pose_excess(session, rec, s, p, quiet[s]) for p in rec.poses]) for s in quiet}
    split = split_by_gyro(session, rec, rate, replay.rate_hz) if "accel" in excess and rate is not None else None
    vibrating = (split is not None and split.rotation_share < 0.5 and split.linear_sigmas >= VIBRATION_SIGMAS)
    share = split.rotation_share if vibrating else 1.0
    spans = [(float(session.t[p.rows[0]]), float(session.t[p.rows[-1]])) for p in rec.poses]
    whites = {s: quiet_noise(session, rec, s) for s in quiet if s not in floors}
    dofs = {s: level_dof(session, rec, s, quiet=True) for s in whites}
    floor = {s: (lambda seed, s=s, w=w, k=k: [ShapedNoise(s, taps=np.ones((3, 1)),
                                                          std=extension_level(w, dofs[s], seed, s, "hold"),
                                                          seed=seed * 7 + 5 + 100_000 * (k + 1))])
             for k, (s, w) in enumerate(whites.items())}
    seen = {"gyro_rate_dps": None if rate is None else math.degrees(rate_across_gravity(session, rec, rate,
                                                                                        replay.rate_hz)),
            "tilt_rate_dps": math.degrees(tilt_rate(session, rec, replay.rate_hz)) if "accel" in quiet else None}
    turning = ("gyro" in excess and ("gyro.spread" in spreads_off or unequal_spreads(session, rec, "gyro"))
               or not vibrating)
    share = share if turning else 0.0          # no rotation named: the accelerometer's disturbance is all vibration
    causes = []
    if turning:
        turned = dict(excess, **({"accel": excess["accel"] * share} if "accel" in excess else {}))
        causes.append(_turning(session, rec, replay, turned, spans,
                               {s: f for s, f in floor.items() if not (vibrating and s == "accel")}, seen))
    if vibrating:
        spectrum = split.linear if turning else split.excess
        causes.append(_vibrating(rec, replay, excess["accel"] * (1.0 - share), spans, split, spectrum,
                                 {s: f for s, f in floor.items() if s == "accel"}, seen))
    return causes


def _turning(session: SessionData, rec: RecordingCalibration, replay: Replay, excess: dict, spans: list,
             floor: dict, seen: dict) -> Cause:
    """`hold_not_still`: each pose's spread beyond the quiet poses' (`quiet_spread`), per axis, as the wobble of the
    gyro and what the accelerometer shows of it. A replica's pose takes the disturbance of a pose drawn from the
    recording's own (gyro and accelerometer together, per axis): the model is that every pose is disturbed by one
    random process, the recording's, not that a given pose was; so a pose's spread is judged against what any pose
    of the recording shows, and a pose disturbed beyond all others stays outside. Between the poses there is none:
    the motions are replayed from the recording's own gyro, which holds whatever the hand did in them (a wobble
    added there too had put the MPU-9150s' carried-gravity errors and the gyro's leave-one-out scatter above the
    recordings'). Sensors whose white noise no other cause sets get the quiet poses' level (`floor`).

    Its size is the gyro's RMS rate during the poses. A recording whose gyro is not analysed (poses a hand held, as
    the MPU-6050's) is named on the accelerometer, sized by the rate at which it sees gravity turn (`tilt_rate`):
    its replicas take the accelerometer's disturbance as it shows, pose by pose."""
    rms = {s: float(np.sqrt(np.mean(e.sum(axis=1)))) for s, e in excess.items()}
    gains = {s: np.sqrt(3 * e) / rms[s] if rms[s] else np.zeros_like(e) for s, e in excess.items()}
    shake = rms.get("accel", 0.0)
    rms_dps = math.degrees(rms["gyro"]) if "gyro" in excess else seen["tilt_rate_dps"]

    def make(seed):
        drawn = drawn_poses(seed, len(spans))
        env = {s: ((-np.inf, np.inf, np.zeros(3)),) + tuple((a, b, g[j]) for (a, b), j in zip(spans, drawn))
               for s, g in gains.items()}
        held = [HoldNotStill("gyro", rms_dps=rms_dps, tau_s=SHAKE_TAU_S, envelope=env["gyro"], seed=seed * 7 + 4)
                ] if "gyro" in env else []
        if "accel" in env:
            held.append(HoldNotStill("accel", shake_rms=shake, tau_s=SHAKE_TAU_S, envelope=env["accel"],
                                     seed=seed * 7 + 4))
        return held
    per_pose = {s: dict(zip([p.name for p in rec.poses], np.sqrt(e.sum(axis=1)).tolist())) for s, e in excess.items()}
    seen_by = "gyro" if "gyro" in excess else "accel"
    return Cause(HoldNotStill.name, seen_by, rms_dps,
                 {"rms_dps": rms_dps, "shake_rms_mps2": shake,
                  "rate_from": "the gyro" if seen_by == "gyro" else
                  f"the accelerometer: the rate at which it sees gravity turn below {TILT_BAND_HZ:g} Hz (a turn "
                  "about gravity, or a faster one, is not seen; a linear acceleration of the hand reads as a turn); "
                  "the replicas carry the disturbance as the accelerometer shows it",
                  "gyro_rate_across_gravity_dps": seen["gyro_rate_dps"],
                  "per_pose_dps": {name: math.degrees(v) for name, v in per_pose.get("gyro", {}).items()},
                  "per_pose_mps2": per_pose.get("accel", {}),
                  "model": "each pose's disturbance, per axis, drawn from the recording's own poses"},
                 ("gyro.spread", "accel.spread", "gyro.adev", "gyro.psd", "accel.adev", "accel.psd"), make,
                 floor=dict(floor))


def _vibrating(rec: RecordingCalibration, replay: Replay, excess: np.ndarray, spans: list, split: Split,
               spectrum: np.ndarray, floor: dict, seen: dict) -> Cause:
    """`vibration`: the accelerometer's excess in each pose and axis that the gyro's rotation does not give, with its
    `spectrum` per octave band (the part no rotation gives; all of the excess where no rotation is named), each
    replica's pose taking that of a pose drawn from the recording's own (`drawn_poses`). Its size is the RMS
    acceleration over the holds."""
    rms = np.sqrt(excess)                                   # (poses, 3) m/s^2
    magnitude = float(np.sqrt(np.mean(excess.sum(axis=1))))
    taps = split.taps(replay.rate_hz, spectrum)
    band = split.band_hz(spectrum)

    def make(seed):
        drawn = drawn_poses(seed, len(spans))
        env = tuple((a, b, rms[j]) for (a, b), j in zip(spans, drawn))
        return [Vibration("accel", taps=taps, envelope=env, band_hz=band, seed=(seed, VIBRATION_STREAM))]
    return Cause(Vibration.name, "accel", magnitude,
                 {"rms_mps2": magnitude, "band_hz": list(band), "rotation_share": split.rotation_share,
                  "sigmas": split.linear_sigmas, **seen,
                  "per_pose_mps2": dict(zip([p.name for p in rec.poses], np.sqrt(excess.sum(axis=1)).tolist())),
                  "model": "each pose's acceleration beyond what the gyro's rotation gives, per axis, drawn from the "
                           "recording's own poses, with the spectrum of that part"},
                 ("accel.spread", "accel.adev", "accel.psd"), make, floor=dict(floor))


def unequal_spreads(session: SessionData, rec: RecordingCalibration, sensor: str, alpha: float = 0.01) -> bool:
    """Whether the poses' spreads of `sensor` differ beyond what one white level gives their samples, on any axis:
    Bartlett's test of equal variances (Snedecor and Cochran, "Statistical Methods", 8th ed., 1989, eq. 13.13.1),
    the three axes' p-values Bonferroni-corrected at alpha."""
    spreads, n = pose_spreads(session, rec, sensor)
    use = n > 2
    if use.sum() < 2:
        return False
    nu = (n[use] - 1.0)[:, None]
    var = np.maximum(spreads[use] ** 2, 1e-300)
    pooled = np.sum(nu * var, axis=0) / nu.sum()
    k = int(use.sum())
    correction = 1 + (np.sum(1 / nu[:, 0]) - 1 / nu.sum()) / (3 * (k - 1))
    statistic = (nu.sum() * np.log(pooled) - np.sum(nu * np.log(var), axis=0)) / correction
    return bool(np.min(chi2.sf(statistic, k - 1)) * 3 < alpha)


def drawn_poses(seed: int, poses: int) -> np.ndarray:
    """Which of the recording's poses each pose of the replica of `seed` takes its disturbance from: the same for
    every cause of the held poses, which are one disturbance seen two ways (drawn apart, a replica's rest, the one
    quiet pose of a hand session, was left quiet by neither in 40 replicas, and fell below all of them)."""
    return np.random.default_rng(seed * 7 + 4).integers(poses, size=poses)


def _pose_excess(session: SessionData, rec: RecordingCalibration, sensor: str, pose, quiet: np.ndarray) -> np.ndarray:
    """Per axis, a pose's variance beyond the quiet level, in calibrated units squared."""
    spread = sampled_rows(session.raw[sensor][pose.rows]).std(axis=0, ddof=1)
    return np.maximum(spread ** 2 - quiet ** 2, 0.0) * np.diag(rec.sensors[sensor].H) ** 2


def tilt_rate(session: SessionData, rec: RecordingCalibration, rate_hz: float) -> float:
    """RMS over the poses of the rate (rad/s) at which gravity turns below `TILT_BAND_HZ`, as the calibrated
    accelerometer sees it: its direction low-passed and differentiated, less what its noise gives through the same
    filter (the quiet poses' per axis, `quiet_poses`, where the noise along gravity drops out of a direction)."""
    from scipy.signal import butter, filtfilt

    cal = rec.sensors["accel"]
    b, a = butter(2, TILT_BAND_HZ, fs=rate_hz)

    def rate_sq(u: np.ndarray) -> np.ndarray:
        slow = filtfilt(b, a, u, axis=0, padlen=min(3 * max(len(a), len(b)), len(u) - 1))
        return np.mean(np.gradient(slow, 1.0 / rate_hz, axis=0) ** 2, axis=0)

    poses = [cal.apply(sampled_rows(session.raw["accel"][p.rows])) for p in rec.poses]
    level = np.array([np.linalg.norm(u.mean(axis=0)) for u in poses])
    noise_sq = np.array([rate_sq(u / g) for u, g in zip(poses, level)])
    quiet = quiet_poses(session, rec, "accel")
    floor = np.array([np.mean(noise_sq[quiet[:, k], k]) for k in range(3)])
    turned = []
    for u in poses:
        d = u / np.linalg.norm(u, axis=1, keepdims=True)
        across = 1.0 - d.mean(axis=0) ** 2 / np.sum(d.mean(axis=0) ** 2)
        turned.append(max(float(np.sum(rate_sq(d)) - np.sum(floor * across)), 0.0))
    return float(np.sqrt(np.mean(turned)))
