"""The replay of a recording without a gyroscope (`procedures.twin.gyroless`): nothing measures how the fixture
turned, so its attitude at every sample is what the data say of it, the calibrated direction of gravity (an
accelerometer), of the field (a magnetometer) or both (TRIAD, Black 1964: the attitude whose two reference
directions are the measured ones, the first exactly). The directions are the calibrated samples smoothed over a
fraction of a second (`smoothed_directions`), so the replicas do not sense the recording's own noise beneath their
own; the magnitudes are the environment's (gravity, the recording's field or the calibration's reference), so
whatever the linear model leaves of the norm is the real recording's alone, which is what the twin compares.
A heading nothing measures (one sensor) is the least turn onto the measured direction, which that sensor cannot
tell from any other."""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter
from scipy.spatial.transform import Rotation

from fixtures.world.model import Environment, SensorModel
from fixtures.world.recorded import RecordedAttitude
from procedures.twin.motion import ReplayedAttitude
from procedures.twin.printed import printed_forms
from procedures.twin.replay import Replay
from rig.calibration.numerics.quantisation import noise_sigma
from rig.calibration.recordings.recording import RecordingCalibration, calibrate_recording
from rig.errors import CalibrationError
from rig.noise.statistics import quantum
from rig.session_data import SessionData, filled

SMOOTHING_S = 0.25          # the span over which a hand's turn is taken as a cubic: the replayed direction
UP = np.array([0.0, 0.0, 1.0])


def smoothed_directions(u: np.ndarray, rate_hz: float) -> np.ndarray:
    """Unit vectors (n, 3) of the calibrated samples u (n, 3, gaps filled), each axis smoothed by a cubic
    Savitzky-Golay filter over `SMOOTHING_S`: the white noise left in them is a fraction of the recording's, and
    falls at the frequencies the recording's noise statistics (second differences) hardly see."""
    window = max(5, int(round(SMOOTHING_S * rate_hz)) | 1)
    if len(u) > window:
        u = savgol_filter(u, window, 3, axis=0, mode="interp")
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def least_turns(body: np.ndarray, world: np.ndarray) -> np.ndarray:
    """R (n, 3, 3), body to world, turned the least so that R^T world = body for each row of the unit vectors
    `body` (n, 3); `world` a unit vector."""
    axis = np.cross(body, world)
    s = np.linalg.norm(axis, axis=1)
    c = np.clip(body @ world, -1.0, 1.0)
    other = np.cross(world, [1.0, 0.0, 0.0] if abs(world[0]) < 0.9 else [0.0, 1.0, 0.0])
    axis = np.where((s > 1e-12)[:, None], axis / np.maximum(s, 1e-300)[:, None], other / np.linalg.norm(other))
    return Rotation.from_rotvec(axis * np.arctan2(s, c)[:, None]).as_matrix()


def triad(first: np.ndarray, second: np.ndarray, first_world: np.ndarray, second_world: np.ndarray) -> np.ndarray:
    """R (n, 3, 3), body to world, with R first = first_world exactly and R second in the plane of the world pair
    (TRIAD: the two orthonormal triads of the pairs, body and world)."""
    def frame(a, b):
        t2 = np.cross(a, b)
        t2 /= np.linalg.norm(t2, axis=-1, keepdims=True)
        return np.stack([a, t2, np.cross(a, t2)], axis=-1)
    body = frame(first, second)
    world = frame(first_world[None], second_world[None])[0]
    return world @ np.swapaxes(body, 1, 2)


def field_noise(y: np.ndarray, counts: bool, replayed: np.ndarray) -> np.ndarray:
    """Per-axis white noise (raw units) of a stream in motion: from its second differences, which a hand's slow turn
    hardly moves, their variance 6 sigma^2 for white noise (`second_difference_noise`), less what the replayed
    motion's own (`replayed`, the noiseless raw stream the replicas sense) adds to them, which every replica has
    beside its noise; ahead of the rounding where the stream is in counts (`noise_sigma`)."""
    spread = second_difference_noise(y[~np.isnan(y).any(axis=1)])
    motion = np.sqrt(np.mean(np.diff(replayed, n=2, axis=0) ** 2, axis=0) / 6.0)
    spread = np.sqrt(np.maximum(spread ** 2 - motion ** 2, 0.0))
    return noise_sigma(spread[None, :]) if counts else spread


def second_difference_noise(rows: np.ndarray, reach: float = 5.0) -> np.ndarray:
    """Per axis, the white noise level of the complete rows (n, 3), rounding included: the root mean square of their
    second differences over sqrt(6), those beyond `reach` robust deviations (1.4826 median absolute deviations) of
    their median left out, a jerk of the hand's among them. The mean square, not the deviation itself, which on a
    stream in counts a few counts wide is a whole count or half of one, the same in every replica."""
    d2 = np.diff(rows, n=2, axis=0)
    centred = d2 - np.median(d2, axis=0)
    robust = 1.4826 * np.median(np.abs(centred), axis=0)
    kept = (np.abs(centred) <= reach * robust) | (robust == 0)
    return np.sqrt(np.sum(np.where(kept, d2, 0.0) ** 2, axis=0) / np.maximum(kept.sum(axis=0), 1) / 6.0)


def reconstruct_from_directions(session: SessionData, rec: RecordingCalibration,
                                statistics) -> Replay:
    """The recording replayed without a gyroscope: the attitude at each sample from the measured directions, each
    sensor `y = inv(H) u + B` of the recording's calibration with the white noise its second differences show,
    every replica calibrated as the recording was and reduced by `statistics`."""
    t = session.t
    rate = float(session.sample_rate_hz or 1.0 / np.median(np.diff(t)))
    cal = {s: c for s, c in rec.sensors.items() if s in session.raw}
    if not cal:
        raise CalibrationError(f"{session.source}: no sensor of the recording was calibrated; the twin has nothing "
                               "to replay")
    direction = {s: smoothed_directions(c.apply(filled(session.raw[s])), rate) for s, c in cal.items()}
    env = Environment(gravity=session.gravity, field_uT=session.field_uT or _field_norm(session, rec))
    if "mag" in direction:
        dip = (float(np.degrees(np.arcsin(np.clip(np.mean(np.sum(direction["accel"] * direction["mag"], axis=1)),
                                                  -1.0, 1.0))))
               if "accel" in direction else 0.0)
        env.dip_deg, env.declination_deg = -dip, 0.0      # the field's angle below the horizon: -(its angle to up)
    if "accel" in direction and "mag" in direction:
        m_world = env.field_world() / env.field_uT
        R = triad(direction["accel"], direction["mag"], UP, m_world)
    elif "accel" in direction:
        R = least_turns(direction["accel"], UP)
    else:
        R = least_turns(direction["mag"], env.field_world() / env.field_uT)
    units = {s: session.meta.get("units", {}).get(s, "counts") for s in cal}
    world = {"accel": env.gravity * UP, "mag": env.field_world()}
    replayed = {s: np.einsum("nji,j->ni", R, world[s]) @ np.linalg.inv(c.H).T + c.B for s, c in cal.items()}
    sensors = {s: SensorModel(s, c.H, c.B, field_noise(session.raw[s], units[s] == "counts", replayed[s]))
               for s, c in cal.items()}
    attitude = ReplayedAttitude(RecordedAttitude(t, R, np.zeros((len(t), 3))), t)
    printed = printed_forms(session, sensors)
    return Replay(t, attitude, sensors, units, {s: np.isnan(session.raw[s]).any(axis=1) for s in sensors}, env,
                  session.meta.get("segments") or [], rate, session.source, calibrate_recording, printed, None, None,
                  statistics, {s: value_grid(session.raw[s]) for s in sensors})


def value_grid(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per axis, the step of the grid the stream's values lie on (`quantum`: 0 where none, a filtered stream in
    counts or one in full precision) and a value on it, the grid's origin: counts times a scale, in physical units,
    lie on a grid coarser than the form they were printed in."""
    step = np.array([quantum(y[:, k]) for k in range(3)])
    origin = np.array([next(iter(y[np.isfinite(y[:, k]), k]), 0.0) for k in range(3)])
    return step, origin


def _field_norm(session: SessionData, rec: RecordingCalibration) -> float:
    """The magnitude the magnetometer's calibration scaled the field to, where the recording names none."""
    mag = rec.sensors.get("mag")
    if mag is None:
        return 50.0
    return float(np.median(np.linalg.norm(mag.apply(filled(session.raw["mag"])), axis=1)))
