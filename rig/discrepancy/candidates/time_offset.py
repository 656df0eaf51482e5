"""The discrepancy analysis's tests of `time_offset` (latency between sensor samples and the reference): on a
turntable session against the table's rate, in a recording against the accelerometer."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from rig.calibration.recordings.recording import RecordingCalibration
from rig.discrepancy.candidates_base import Candidate, candidate_test
from rig.discrepancy.recording_base import Test, recording_test, subsample
from rig.noise.stream_delay import recording_delays, robust_delay
from rig.session_data import SessionData


@candidate_test("time_offset", needs=("moves",))
def time_offset(sensor: str) -> Candidate:
    return Candidate(lambda o, f: -o.rate_dot[:, :, None], ("t",), lambda c: float(c[0]), lambda c: {"tau_s": float(c[0])},
                     note="sensor reads omega(t - tau): residual = -tau d(omega)/dt",
                     against=lambda o: (np.degrees(o.rate_dot), "reference d(omega)/dt, deg/s^2"))


@recording_test("time_offset")
def in_a_recording(session: SessionData, rec: RecordingCalibration, table: dict,
                    rng: np.random.Generator | None = None) -> list[Test]:
    """The gyro's delay behind the accelerometer (the reference), one estimate per motion from the turning gravity
    direction, the motions' robust mean tested against zero (`rig.noise.stream_delay`: a hand's linear
    acceleration fitted as a lever arm in each motion, Huber's mean of the motions, its t). A summed rotation (carried
    gravity, a turn's angle) cannot see the delay: it integrates through. Where a magnetometer is calibrated too,
    the field's direction gives the gyro's delay behind it, stated beside (with the magnetometer's own delay behind
    the accelerometer, their difference); where gravity turns too little in the motions, the field's is the test.
    With `rng`, the motions are subsampled (80 %, without replacement)."""
    delays = recording_delays(session, rec)
    if rng is not None:
        delays = {s: d for s, d in ((s, robust_delay(list(rng.choice(d.per_motion, subsample(len(d.per_motion)),
                                                                     replace=False)))) for s, d in delays.items())
                  if d is not None}
    reference = "accel" if "accel" in delays else "mag" if "mag" in delays else None
    if reference is None:
        return []
    found = delays[reference]
    p = float(2 * stats.t.sf(abs(found.value) / found.sd, found.dof)) if found.sd > 0 else 1.0
    params = {"tau_s": found.value, "reference": reference, "per_motion_s": found.per_motion,
              "positive": "gyro lags the accelerometer" if reference == "accel" else "gyro lags the magnetometer"}
    if reference == "accel" and "mag" in delays:
        mag = delays["mag"]
        params.update({"behind_mag_s": mag.value, "behind_mag_sd_s": mag.sd,
                       "mag_behind_accel_s": found.value - mag.value,
                       "mag_behind_accel_sd_s": math.hypot(found.sd, mag.sd)})
    return [Test("time_offset", "gyro", p, found.value, found.sd, params)]
