"""The statistics a twin compares on a recording without a gyroscope (`procedures.twin.gyroless`): every sample of
every calibrated sensor, still or not, since no rate says which were held. Per sensor: the calibrated norm against
the environment's (its scatter, its mean, and its mean over each tenth of the recording, which a change in time,
an offset that steps, moves), the white noise its second differences show per axis, the step of the grid its
values lie on and the share pinned at a rail; with both an accelerometer and a magnetometer, the angle between
field and gravity (its scatter), which the frame between the two sets. Only sensors the recording holds and its
calibration covers are read."""

from __future__ import annotations

import numpy as np

from procedures.twin.directions import second_difference_noise
from rig.calibration.recordings.recording import RecordingCalibration
from rig.noise.statistics import STEP_DIGITS, pinned_fraction, quantum
from rig.session_data import SessionData

AXES = "xyz"
SLICES = 10                # the recording's tenths, whose mean norms a change in time moves apart


def reference_norm(session: SessionData, sensor: str) -> float | None:
    """The magnitude a calibrated sensor should read: gravity, or the recording's field (None where it names none:
    the calibration's own scale is then the reference, read off the samples)."""
    return float(session.gravity) if sensor == "accel" else (float(session.field_uT) if session.field_uT else None)


def field_statistics(session: SessionData, rec: RecordingCalibration) -> dict[str, float]:
    """Every statistic of `session` calibrated as `rec`, by name (`<sensor>.<family>...`)."""
    out: dict[str, float] = {}
    units = {}
    for sensor in ("accel", "mag"):
        if sensor not in session.raw or sensor not in rec.sensors:
            continue
        y = session.raw[sensor]
        complete = ~np.isnan(y).any(axis=1)
        rows = y[complete]
        u = rec.sensors[sensor].apply(rows)
        units[sensor] = np.full((len(y), 3), np.nan)
        units[sensor][complete] = u / np.linalg.norm(u, axis=1, keepdims=True)
        norm = np.linalg.norm(u, axis=1)
        ref = reference_norm(session, sensor) or float(np.median(norm))
        relative = norm / ref - 1.0
        out[f"{sensor}.norm_scatter"] = float(relative.std(ddof=1))
        out[f"{sensor}.norm_mean"] = float(relative.mean())
        for k, part in enumerate(np.array_split(relative, SLICES)):
            if len(part):
                out[f"{sensor}.norm_residual[tenth {k + 1}]"] = float(part.mean())
        noise = second_difference_noise(rows)
        for k in range(3):
            out[f"{sensor}.noise.{AXES[k]}"] = float(noise[k])
            out[f"{sensor}.step.{AXES[k]}"] = float(f"{quantum(rows[:, k]):.{STEP_DIGITS}g}")
            out[f"{sensor}.pinned.{AXES[k]}"] = pinned_fraction(rows[:, k])
    if len(units) == 2:
        both = ~np.isnan(units["accel"]).any(axis=1) & ~np.isnan(units["mag"]).any(axis=1)
        if both.sum() > 2:
            angle = np.degrees(np.arccos(np.clip(np.sum(units["accel"][both] * units["mag"][both], axis=1), -1, 1)))
            out["mag.dip_scatter"] = float(angle.std(ddof=1))
    return out
