"""The simulation's twin of a real recording: the same poses and motions, the parameters fitted to it, the noise
model the simulator uses, run many times through the same calibration and statistics. This is
the replay every replica shares (`procedures.twin.replicas` runs them): the recording's motion, sensors and
environment, reconstructed once.

Reconstruction: each static pose keeps the gravity direction the calibrated accelerometer measured there; between
poses the fixture turns as the calibrated gyro says, sample for sample; the heading, which nothing measures, is
carried along by the gyro.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from fixtures.world.effects_base import Effect
from fixtures.world.model import AttitudeMotion, Environment, SensorModel
from fixtures.world.recorded import HeldAttitude, RecordedAttitude
from procedures.twin.motion import ReplayedAttitude, attitudes, unit
from procedures.twin.draws import noise_dof
from procedures.twin.noise import sampled_rows, white_noise
from procedures.twin.printed import Printed, printed_forms
from rig.calibration.recordings.carry_weight import CarryWeight
from rig.calibration.recordings.recording import RecordingCalibration, calibrate_recording
from rig.errors import CalibrationError
from rig.noise.statistics import recording_statistics
from rig.noise.still_log import is_still_log_calibration, still_log_calibration
from rig.noise.stream_delay import hand_acceleration
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
    printed: dict[str, Printed] | None = None  # how the recording wrote each sensor in physical units
    noise_dof: dict[str, float] | None = None  # degrees of freedom of each white noise level estimated from the poses
    hand: np.ndarray | None = None        # (n, 3) m/s^2 the accelerometer reads beside gravity through the motions
    # what every replica is reduced to, given its calibration: the recording's statistics (a recording without a
    # gyroscope has no poses held to read them on: `procedures.twin.field_statistics`)
    statistics: Callable[[SessionData, RecordingCalibration], dict[str, float]] = recording_statistics
    # sensor -> (step, origin) per axis, raw units: the grid the recording's values lie on, onto which a replica's
    # are rounded in place of counts (a step 0: an axis on no grid, in full precision or in its printed form)
    grid: dict[str, tuple[np.ndarray, np.ndarray]] | None = None


@dataclass
class HandAcceleration(Effect):
    """The recording's own hand acceleration through its motions (`rig.noise.stream_delay.hand_acceleration`: the
    lever arm fitted in each motion), read by every replica's accelerometer beside gravity: part of the replayed
    motion, as the rate is, not a cause. Without it the replicas' accelerometers read gravity alone through a hand's
    motions, and a recording's delay between gyro and accelerometer was judged against a band that knew nothing of
    the lever arm its estimate fits (a clean hand turned about a point 15 cm away fell outside)."""

    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    a: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def input(self, ctx, u):
        if ctx.t.shape == self.t.shape and np.array_equal(ctx.t, self.t):
            return u + self.a
        return u + np.stack([np.interp(ctx.t, self.t, self.a[:, k], left=0.0, right=0.0) for k in range(3)], axis=1)


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
    up = [unit(rec.sensors["accel"].apply(sampled_rows(session.raw["accel"][p.rows]).mean(axis=0, keepdims=True))[0])
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
    R = attitudes(grid, omega, pose_of, up)
    sensors = {name: SensorModel(name, cal.H, cal.B, white_noise(session, name, rec))
               for name, cal in rec.sensors.items() if name in session.raw}
    env = Environment(gravity=session.gravity, field_uT=session.field_uT or 50.0)
    if "mag" in sensors:
        field = [rec.sensors["mag"].apply(sampled_rows(session.raw["mag"][p.rows]).mean(axis=0, keepdims=True))[0]
                 for p in rec.poses]
        m_world = np.mean([R[p.rows[0]] @ m for p, m in zip(rec.poses, field)], axis=0)
        R = attitudes(grid, omega, pose_of, up, (field, m_world))
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
                  printed_forms(session, sensors), {name: noise_dof(session, name, rec) for name in sensors},
                  None if held else hand_acceleration(session, rec))


def replica_calibration(rec: RecordingCalibration) -> Callable[[SessionData], RecordingCalibration]:
    """How every replica is calibrated: as the recording was. A recording's poses and motions keep its trust in its
    hand motions, and the gyro's fit starts at its H (the same optimum, in a third less time); a still log's
    replica gives its own mean back (`still_log_calibration`)."""
    if is_still_log_calibration(rec):
        return still_log_calibration
    gyro = rec.sensors.get("gyro")
    return partial(calibrate_recording, carry=CarryWeight.from_extra(gyro.extra) if gyro else None,
                   gyro_start=gyro.H if gyro else None)


def _rate(session: SessionData, rec: RecordingCalibration) -> np.ndarray:
    """The calibrated gyro rate (rad/s), gaps filled, not smoothed: a moving mean over a hand motion of hundreds of
    deg/s changes the rotation it integrates to (a 5-sample mean moved imucal's SI turns by up to 0.03 deg and its
    carried gravity by up to 0.06 deg, each beyond the replicas' band), while the recording's own noise, replayed
    with the motion, stays in it under any smoothing that keeps the motion's sum. Without a gyro, none: each pose's
    attitude is held until the next (`poses_alone`)."""
    if "gyro" not in rec.sensors:
        return np.zeros((len(session.t), 3))
    return rec.sensors["gyro"].apply(filled(session.raw["gyro"]))
