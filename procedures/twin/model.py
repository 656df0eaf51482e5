"""Model effects the recording tests find (`rig.discrepancy.recording`) as causes for the twin: a significant
g-sensitivity, bias drift, delay or even term is put into the simulated world at its fitted size before any
noise effect is proposed, so a systematic effect is not misnamed as noise (the Xsens gyro's pose means follow
the specific force at 0.2 deg/s per g, which without this the twin could only call bias instability)."""

from __future__ import annotations

import copy
from collections.abc import Callable

import numpy as np

from fixtures.world import EFFECTS
from procedures.twin.cause import Cause
from rig.calibration.recordings.heldout import heldout_scores
from rig.calibration.recordings.recording import RecordingCalibration
from rig.discrepancy.recording import recording_tests
from rig.errors import CalibrationError
from rig.session_data import SessionData, filled


def model_causes(session: SessionData, rec: RecordingCalibration) -> tuple[list[Cause], list[dict]]:
    """The significant findings as twin causes, and every test run (significant or not) for the report."""
    tests = recording_tests(session, rec)
    causes = [cause for t in tests if t["significant"] and (cause := _cause(t)) is not None]
    return causes, tests


def centred(causes: list[Cause], before: dict) -> list[Cause]:
    """The model causes whose term reads its size off a statistic of the twin (`twin_offset_statistic`: the gyro's
    delay) with what the plain twin's replicas read of it (`before`, the bands' median) taken off: a replica given
    the recording's estimate reads it with the estimator's own offset on these motions added once more. A synthetic
    hand 40 ms late read 39.91 ms, its replicas given 39.91 read 39.77 +- 0.07, and the cause brought nothing back."""
    out = []
    for cause in causes:
        statistic = getattr(EFFECTS.get(cause.effect), "twin_offset_statistic", None) if cause.model else None
        if statistic is None or statistic not in before:
            out.append(cause)
            continue
        test = {"effect": cause.effect, "sensor": cause.sensor, "magnitude": cause.magnitude,
                "params": dict(cause.params, twin_magnitude=cause.magnitude - before[statistic][2])}
        out.append(_cause(test) or cause)
    return out


def added_rate(causes: list[Cause]) -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
    """What the gyro causes add to the rate (rad/s) at times t and calibrated specific force f (m/s^2): the
    twin's replayed motion is the recording's gyro less this (`procedures.twin.replay.reconstruct`)."""
    terms = [c.rate for c in causes if c.rate is not None]
    if not terms:
        return None
    return lambda t, f: sum(term(t, f) for term in terms)


def heldout_change(session: SessionData, rec: RecordingCalibration, causes: list[Cause]) -> dict | None:
    """The held-out scores of item 2 (`rig.calibration.recordings.heldout`) before and after the gyro causes are taken
    into the calibration: the rate they add removed from the raw gyro stream (relative to the poses' average, which the
    bias holds) before every refit. The causes were fitted on the pose means, not on the motions scored."""
    rate = added_rate(causes)
    if rate is None:
        return None
    f = rec.sensors["accel"].apply(filled(session.raw["accel"]))
    stills = np.concatenate([p.rows for p in rec.poses])
    extra = rate(session.t, f)
    extra -= extra[stills].mean(axis=0)
    corrected = copy.copy(session)
    corrected.raw = dict(session.raw, gyro=session.raw["gyro"] - extra @ np.linalg.inv(rec.sensors["gyro"].H).T)
    before, _ = heldout_scores(session)
    after, _ = heldout_scores(corrected)
    return {"causes": [c.effect for c in causes if c.rate is not None], "before": before.summary(),
            "after": after.summary()}


def _cause(test: dict) -> Cause | None:
    """A finding as a cause, where its simulator term says how the twin takes it (`from_recording_test`)."""
    term = EFFECTS[test["effect"]]
    if not term.twin_statistics:
        return None
    sensor, magnitude, params = test["sensor"], test["magnitude"], test["params"]
    effect = term.from_recording_test(sensor, magnitude, params)
    return Cause(test["effect"], sensor, magnitude, params, term.twin_statistics,
                 lambda seed: [term.from_recording_test(sensor, magnitude, params)], rate=effect.added_rate, model=True)


class NothingCalibrated(CalibrationError):
    """No sensor of the recording could be calibrated: nothing is analysed, as `calibrate --from` writes nothing
    calibrated (a check that did not pass, not a fault)."""


def something_calibrated(session: SessionData, rec: RecordingCalibration) -> RecordingCalibration:
    """`rec` where it calibrated a sensor; a twin needs one, so a recording none of whose sensors could be
    calibrated is refused with each sensor's reason (what `rig calibrate --from` writes under not_calibrated)."""
    if rec.sensors:
        return rec
    reasons = "; ".join(f"{sensor}: {why}" for sensor, why in rec.refused.items()) or "no sensor to calibrate"
    raise NothingCalibrated(f"{session.source}: no sensor of this recording could be calibrated, so it has no twin "
                           f"to compare with ({reasons})")
