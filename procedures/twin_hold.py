"""Poses that are not still (effects.md `hold_not_still`): a hand or a soft mount disturbs each pose by its own
amount, which the twin measures pose by pose against the quiet poses' level and gives to its replicas."""

from __future__ import annotations

import math

import numpy as np

from fixtures.world.effects.noise import HoldNotStill, ShapedNoise
from procedures.twin_cause import Cause
from procedures.twin_draws import extension_level, level_dof
from procedures.twin_noise import quiet_noise, quiet_poses, quiet_spread, sampled_rows
from procedures.twin_replay import Replay
from rig.calibration.recording import RecordingCalibration
from rig.session_data import SessionData

SHAKE_TAU_S = 0.05        # a hand's tremor (8-12 Hz) and a soft mount's ringing, as a correlation time
TILT_BAND_HZ = 2.0        # a hand's sway: below it gravity turns by enough for the accelerometer to see


def hold_not_still(session: SessionData, rec: RecordingCalibration, replay: Replay, floors: dict) -> Cause:
    """Poses that move: each pose's spread beyond the quiet poses' (`quiet_spread`), per axis, as the wobble of the
    gyro and the shake of the accelerometer. A replica's pose takes the disturbance of a pose drawn from the
    recording's own (gyro and accelerometer together, per axis): the model is that every pose is disturbed by one
    random process, the recording's, not that a given pose was; so a pose's spread is judged against what any pose
    of the recording shows, and a pose disturbed beyond all others stays outside. Between the poses there is none:
    the motions are replayed from the recording's own gyro, which holds whatever the hand did in them (a wobble
    added there too had put the MPU-9150s' carried-gravity errors and the gyro's leave-one-out scatter above the
    recordings'). Sensors whose white noise no other cause sets (`floors`) get the quiet poses' level here.

    Its size is the gyro's RMS rate during the poses. A recording whose gyro is not analysed (poses a hand held, as
    the MPU-6050's) is named on the accelerometer, sized by the rate at which it sees gravity turn (`tilt_rate`):
    its replicas take the accelerometer's disturbance as it shows, pose by pose."""
    quiet = {s: quiet_spread(session, rec, s) for s in ("gyro", "accel") if s in replay.sensors}
    excess = {s: np.array([_pose_excess(session, rec, s, p, quiet[s]) for p in rec.poses]) for s in quiet}
    spans = [(float(session.t[p.rows[0]]), float(session.t[p.rows[-1]])) for p in rec.poses]
    rms = {s: float(np.sqrt(np.mean(e.sum(axis=1)))) for s, e in excess.items()}
    gains = {s: np.sqrt(3 * e) / rms[s] if rms[s] else np.zeros_like(e) for s, e in excess.items()}
    whites = {s: quiet_noise(session, rec, s) for s in quiet if s not in floors}
    dofs = {s: level_dof(session, rec, s, quiet=True) for s in whites}
    shake = rms.get("accel", 0.0)
    rms_dps = math.degrees(rms["gyro"] if "gyro" in quiet else tilt_rate(session, rec, replay.rate_hz))

    def make(seed):
        drawn = np.random.default_rng(seed * 7 + 4).integers(len(spans), size=len(spans))
        env = {s: ((-np.inf, np.inf, np.zeros(3)),) + tuple((a, b, g[j]) for (a, b), j in zip(spans, drawn))
               for s, g in gains.items()}
        noise = [ShapedNoise(s, taps=np.ones((3, 1)), std=extension_level(w, dofs[s], seed, s, "hold"),
                             seed=seed * 7 + 5 + 100_000 * (k + 1))
                 for k, (s, w) in enumerate(whites.items())]
        held = [HoldNotStill("gyro", rms_dps=rms_dps, tau_s=SHAKE_TAU_S, envelope=env["gyro"], seed=seed * 7 + 4)
                ] if "gyro" in env else []
        if "accel" in env:
            held.append(HoldNotStill("accel", shake_rms=shake, tau_s=SHAKE_TAU_S, envelope=env["accel"],
                                     seed=seed * 7 + 4))
        return noise + held
    per_pose = {s: dict(zip([p.name for p in rec.poses], np.sqrt(e.sum(axis=1)).tolist())) for s, e in excess.items()}
    seen_by = "gyro" if "gyro" in quiet else "accel"
    return Cause(HoldNotStill.name, seen_by, rms_dps,
                 {"rms_dps": rms_dps, "shake_rms_mps2": shake,
                  "rate_from": "the gyro" if seen_by == "gyro" else
                  f"the accelerometer: the rate at which it sees gravity turn below {TILT_BAND_HZ:g} Hz (a turn "
                  "about gravity, or a faster one, is not seen; a linear acceleration of the hand reads as a turn); "
                  "the replicas carry the disturbance as the accelerometer shows it",
                  "per_pose_dps": {name: math.degrees(v) for name, v in per_pose.get("gyro", {}).items()},
                  "per_pose_mps2": per_pose.get("accel", {}),
                  "model": "each pose's disturbance, per axis, drawn from the recording's own poses"},
                 ("gyro.spread", "accel.spread", "gyro.adev", "gyro.psd", "accel.adev", "accel.psd"), make,
                 quiet=tuple(whites))


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
