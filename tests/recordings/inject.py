"""Known effects added to a real recording, each by its simulator term's law for recordings
(`into_recording`, effects.md), at the term's realistic sizes (effects-research.md section 4): the analysis must
find them blind on top of the real noise."""

from __future__ import annotations

import copy

import numpy as np

from fixtures.world.effects import EFFECTS as TERMS
from fixtures.world.effects_base import RANGES
from rig.calibration.recordings.recording import RecordingCalibration
from rig.effects import EFFECTS as VOCABULARY
from rig.session_data import SessionData

# effect -> its simulator term's realistic range on the sensor a recording shows it on, for every term that says how
# it adds itself to a recording (`into_recording`)
SIZES = {name: RANGES[(name, TERMS[name].recording_sensor)] for name in VOCABULARY
         if name in TERMS and TERMS[name].recording_sensor}


def _calibrated(session: SessionData, rec: RecordingCalibration, sensor: str) -> np.ndarray:
    y = session.raw[sensor].copy()
    have = ~np.isnan(y).any(axis=1)
    for k in range(3):
        y[:, k] = np.interp(session.t, session.t[have], y[have, k])
    return rec.sensors[sensor].apply(y)


def _raw(rec: RecordingCalibration, sensor: str, u: np.ndarray) -> np.ndarray:
    cal = rec.sensors[sensor]
    return u @ np.linalg.inv(cal.H).T + cal.B


def inject(session: SessionData, rec: RecordingCalibration, effect: str, size: float, rng) -> tuple[SessionData, dict]:
    """A copy of the recording with `effect` of `size` (the vocabulary's magnitude) added; and what was added."""
    out = copy.copy(session)
    out.raw = dict(session.raw)
    term = TERMS[effect]
    calibrated = {sensor: _calibrated(session, rec, sensor) for sensor in ("accel", "gyro") if sensor in rec.sensors}
    stream, added = term.into_recording(rng, size, session.t, calibrated)
    sensor = term.recording_sensor
    out.raw[sensor] = _keep_gaps(session.raw[sensor], _raw(rec, sensor, stream))
    return out, added


def _keep_gaps(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    after = after.copy()
    after[np.isnan(before).any(axis=1)] = np.nan
    return after
