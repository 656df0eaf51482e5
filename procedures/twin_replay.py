"""The simulation's twin of a real recording: the same poses and motions, the parameters fitted to it, the noise
model the simulator uses, run many times through the same calibration and statistics (issue 13, item 3). This is
the replay every replica shares (`procedures.twin_replicas` runs them): the recording's motion, sensors and
environment, reconstructed once.

Reconstruction: each static pose keeps the gravity direction the calibrated accelerometer measured there; between
poses the fixture turns as the calibrated gyro says, sample for sample; the heading, which nothing measures, is
carried along by the gyro.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from fixtures.world.model import AttitudeMotion, Environment, SensorModel
from fixtures.world.recorded import HeldAttitude, RecordedAttitude
from procedures.twin_noise import noise_dof, printed_decimals, sampled_rows, white_noise
from rig.calibration.carry_weight import CarryWeight
from rig.calibration.recording import RecordingCalibration, calibrate_recording
from rig.errors import CalibrationError
from rig.noise.still_log import is_still_log_calibration, still_log_calibration
from rig.rotations import matrix_from_rotvec
from rig.session_data import SessionData, filled


@dataclass
class Replay:
    """What every replica of one recording shares."""

    t: np.ndarray
    attitude: AttitudeMotion
    sensors: dict[str, SensorModel]       # raw units: y = inv(H) u + B + noise
    units: dict[str, str]
    missing: dict[str, np.ndarray]        # rows where the recording had no sample of the sensor
    env: Environment
    segments: list[dict]
    rate_hz: float
    source: str
    calibrate: Callable[[SessionData], RecordingCalibration]   # every replica's calibration: the recording's
    decimals: dict[str, int] | None = None  # sensors in physical units the recording printed with so many decimals
    noise_dof: dict[str, float] | None = None  # degrees of freedom of each white noise level estimated from the poses


def twin_view(session: SessionData, rec: RecordingCalibration) -> SessionData:
    """The recording with its static poses as segments: those it named, or those its calibration found."""
    if session.meta.get("segments"):
        return session
    view = copy.copy(session)
    view.meta = dict(session.meta, segments=pose_segments(session, rec))
    return view


def poses_alone(view: SessionData, rec: RecordingCalibration, dropped: set[str]) -> SessionData:
    """The view without the `dropped` sensors and with the others' samples on the static poses only: without a
    calibrated gyro nothing replays the motions between poses, so neither the recording nor its replicas have them
    (the replicas hold a pose's attitude until the next, and those rows are as empty as the recording's)."""
    on_pose = np.zeros(len(view.t), dtype=bool)
    for p in rec.poses:
        on_pose[p.rows] = True
    out = copy.copy(view)
    out.raw = {s: np.where(on_pose[:, None], y, np.nan) for s, y in view.raw.items() if s not in dropped}
    return out


def pose_segments(session: SessionData, rec: RecordingCalibration) -> list[dict]:
    return [{"name": p.name, "t0": float(session.t[p.rows[0]]), "t1": float(session.t[p.rows[-1]]), "kind": "static"}
            for p in rec.poses]


def reconstruct(session: SessionData, rec: RecordingCalibration,
                added_rate: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> Replay:
    """The motion, sensors and environment of the recording as the twin replays them.

    The motion between poses is the calibrated gyro's; `added_rate(t, f)` is what a model effect adds to that rate
    (rad/s, from time and calibrated specific force, relative to the poses' average, which the bias holds), taken
    out so that the twin, which adds the effect itself, does not replay it twice."""
    t = session.t
    n = len(t)
    if "accel" not in rec.sensors:
        raise CalibrationError("twin: the recording needs an accelerometer")
    pose_of = np.full(n, -1)
    for k, p in enumerate(rec.poses):
        pose_of[p.rows] = k
    up = [_unit(rec.sensors["accel"].apply(sampled_rows(session.raw["accel"][p.rows]).mean(axis=0, keepdims=True))[0])
          for p in rec.poses]
    held = len(rec.poses) == 1 and bool((pose_of == 0).all())     # a still log: one attitude, no motion
    if held:                                                          # reconstructed at its first sample alone
        grid, pose_of, omega = t[:1], pose_of[:1], np.zeros((1, 3))
    else:
        grid, omega = t, _rate(session, rec)
        if added_rate is not None:
            f = rec.sensors["accel"].apply(filled(session.raw["accel"]))
            omega -= added_rate(t, f) - added_rate(t, f)[pose_of >= 0].mean(axis=0)
        omega[pose_of >= 0] = 0.0
    R = _attitudes(grid, omega, pose_of, up)
    sensors = {name: SensorModel(name, cal.H, cal.B, white_noise(session, name, rec))
               for name, cal in rec.sensors.items() if name in session.raw}
    env = Environment(gravity=session.gravity, field_uT=session.field_uT or 50.0)
    if "mag" in sensors:
        field = [rec.sensors["mag"].apply(sampled_rows(session.raw["mag"][p.rows]).mean(axis=0, keepdims=True))[0]
                 for p in rec.poses]
        m_world = np.mean([R[p.rows[0]] @ m for p, m in zip(rec.poses, field)], axis=0)
        R = _attitudes(grid, omega, pose_of, up, (field, m_world))
        m_world = np.mean([R[p.rows[0]] @ m for p, m in zip(rec.poses, field)], axis=0)
        env.field_uT = float(np.linalg.norm(m_world))
        env.dip_deg = float(np.degrees(np.arcsin(-m_world[2] / env.field_uT)))
        env.declination_deg = float(np.degrees(np.arctan2(m_world[0], m_world[1])))
    if session.temp_c is not None and np.isfinite(session.temp_c).all():
        env.temperature = lambda tt, tc=session.temp_c: np.interp(tt, t, tc)
    attitude = HeldAttitude.of(R[0]) if held else ReplayedAttitude(RecordedAttitude(t, R, omega), t)
    return Replay(t, attitude, sensors,
                  {s: session.meta.get("units", {}).get(s, "counts") for s in sensors},
                  {s: np.isnan(session.raw[s]).any(axis=1) for s in sensors}, env,
                  session.meta.get("segments") or pose_segments(session, rec),
                  float(session.sample_rate_hz or 1.0 / np.median(np.diff(t))), session.source,
                  replica_calibration(rec),
                  printed_decimals(session, sensors), {name: noise_dof(session, name, rec) for name in sensors})


def replica_calibration(rec: RecordingCalibration) -> Callable[[SessionData], RecordingCalibration]:
    """How every replica is calibrated: as the recording was. A recording's poses and motions keep its trust in its
    hand motions, and the gyro's fit starts at its H (the same optimum, in a third less time); a still log's
    replica gives its own mean back (`still_log_calibration`)."""
    if is_still_log_calibration(rec):
        return still_log_calibration
    gyro = rec.sensors.get("gyro")
    return partial(calibrate_recording, carry=CarryWeight.from_extra(gyro.extra) if gyro else None,
                   gyro_start=gyro.H if gyro else None)


def _attitudes(t: np.ndarray, omega: np.ndarray, pose_of: np.ndarray, up: list[np.ndarray],
               heading: tuple[list[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """R(t) (n, 3, 3): turned the least onto each pose's gravity direction where the pose begins, held through
    it, and between poses carried by the rate, one trapezoid step per sample. The steps' rotations are formed
    at once; only their product runs in order, over the samples where something changes. With `heading` (each
    pose's calibrated field, the world's field) a pose is also turned about the vertical so that its field points
    where the world's does: the magnetometer measured the heading there, which the rate carried across the
    motions misses by up to a degree on a Ferraris session; its replicas' pose fields were up to 0.65 uT
    (twice the noise) off the recording's, which moved the value step of a stream in full precision."""
    n = len(t)
    R = np.empty((n, 3, 3))
    current = _align(np.eye(3), up[pose_of[0]] if pose_of[0] >= 0 else _unit(np.array([0.0, 0.0, 1.0])))
    entry = (pose_of >= 0) & np.r_[True, pose_of[1:] != pose_of[:-1]]
    moving = np.r_[False, pose_of[1:] < 0]
    i_move = np.flatnonzero(moving)
    steps = iter(matrix_from_rotvec(0.5 * (omega[i_move - 1] + omega[i_move]) * (t[i_move] - t[i_move - 1])[:, None]))
    changes = np.flatnonzero(entry | moving)
    ends = np.r_[changes[1:], n]
    R[:changes[0] if changes.size else n] = current
    for i, end in zip(changes, ends):         # the moving rows among the changes are i_move, in order
        current = _align(current, up[pose_of[i]]) if entry[i] else current @ next(steps)
        if heading is not None and entry[i]:
            current = _head(current, heading[0][pose_of[i]], heading[1])
        R[i:end] = current
    return R


class ReplayedAttitude:
    """The replayed attitude evaluated once on the recording's own time grid, which every replica senses (each
    sensor of each replica: 360 evaluations of 51 175 attitudes for the Xsens, a tenth of its analysis); other
    times (a stream delayed by an effect) are interpolated as before. On the grid, callers get read-only views, not
    copies: nothing they do reaches the next replica, and a replica of a 6-hour log does not hold 207 MiB more per
    sensor (an attempt to write raises). The rate on the grid is the recorded rate itself, which the
    interpolation gives back there."""

    def __init__(self, recorded: RecordedAttitude, t: np.ndarray) -> None:
        self.recorded = recorded
        self.t = np.asarray(t, dtype=float)
        self._R_on_grid = recorded.attitude(self.t)[0]

    def attitude(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.shape == self.t.shape and np.array_equal(t, self.t):
            return _read_only(self._R_on_grid), _read_only(self.recorded.omega)
        return self.recorded.attitude(t)


def _read_only(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


def _rate(session: SessionData, rec: RecordingCalibration) -> np.ndarray:
    """The calibrated gyro rate (rad/s), gaps filled, not smoothed: a moving mean over a hand motion of hundreds of
    deg/s changes the rotation it integrates to (a 5-sample mean moved imucal's SI turns by up to 0.03 deg and its
    carried gravity by up to 0.06 deg, each beyond the replicas' band), while the recording's own noise, replayed
    with the motion, stays in it under any smoothing that keeps the motion's sum. Without a gyro, none: each pose's
    attitude is held until the next (`poses_alone`)."""
    if "gyro" not in rec.sensors:
        return np.zeros((len(session.t), 3))
    return rec.sensors["gyro"].apply(filled(session.raw["gyro"]))


def _align(R: np.ndarray, u: np.ndarray) -> np.ndarray:
    """R turned the least (in the fixture) so that world up, seen in the fixture, is u: R^T z = u."""
    v = R.T @ np.array([0.0, 0.0, 1.0])
    axis = np.cross(u, v)
    s, c = np.linalg.norm(axis), float(np.clip(u @ v, -1.0, 1.0))
    if s < 1e-12:
        return R if c > 0 else R @ matrix_from_rotvec(np.pi * _unit(np.cross(v, [1.0, 0.0, 0.0])
                                                                    if abs(v[0]) < 0.9 else np.cross(v, [0, 1.0, 0])))
    return R @ matrix_from_rotvec(axis / s * np.arctan2(s, c))


def _head(R: np.ndarray, m: np.ndarray, m_world: np.ndarray) -> np.ndarray:
    """R turned about world up so that the field m, seen in the fixture, points horizontally where m_world does."""
    a = R @ m
    if not (np.isfinite(a).all() and np.isfinite(m_world).all()):      # a pose without a field sample keeps its heading
        return R
    psi = np.arctan2(m_world[1], m_world[0]) - np.arctan2(a[1], a[0])
    return matrix_from_rotvec(np.array([0.0, 0.0, psi])) @ R


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)
