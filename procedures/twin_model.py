"""Model effects the recording tests find (`rig.discrepancy.recording`) as causes for the twin: a significant
g-sensitivity, bias drift, delay or even term is put into the simulated world at its fitted size before any
noise effect is proposed, so a systematic effect is not misnamed as noise (the Xsens gyro's pose means follow
the specific force at 0.2 deg/s per g, which without this the twin could only call bias instability)."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable

import numpy as np

from fixtures.world import EFFECTS
from procedures.twin_extension import Cause
from rig.calibration.heldout import heldout_scores
from rig.calibration.recording import RecordingCalibration
from rig.discrepancy.recording import recording_tests
from rig.session_data import SessionData, filled

G0 = 9.80665
DEG = math.pi / 180
GYRO_MEANS = ("gyro.hold_mean", "gyro.bias_scatter")
GYRO_MOTION = ("gyro.turn_error", "gyro.carry_error")


def model_causes(session: SessionData, rec: RecordingCalibration) -> tuple[list[Cause], list[dict]]:
    """The significant findings as twin causes, and every test run (significant or not) for the report."""
    tests = recording_tests(session, rec)
    causes = [cause for t in tests if t["significant"] and (cause := _cause(t)) is not None]
    return causes, tests


def added_rate(causes: list[Cause]) -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
    """What the gyro causes add to the rate (rad/s) at times t and calibrated specific force f (m/s^2): the
    twin's replayed motion is the recording's gyro less this (`procedures.twin.reconstruct`)."""
    terms = [c.rate for c in causes if c.rate is not None]
    if not terms:
        return None
    return lambda t, f: sum(term(t, f) for term in terms)


def heldout_change(session: SessionData, rec: RecordingCalibration, causes: list[Cause]) -> dict | None:
    """The held-out scores of item 2 (`rig.calibration.heldout`) before and after the gyro causes are taken into the
    calibration: the rate they add removed from the raw gyro stream (relative to the poses' average, which the
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
    p = test["params"]
    if test["effect"] == "gyro_g_sensitivity":
        Gs = np.array(p["G_deg_s_per_g"]) * DEG / G0
        return Cause("gyro_g_sensitivity", "gyro", test["magnitude"], p, GYRO_MEANS,
                     lambda seed, Gs=Gs: [EFFECTS["gyro_g_sensitivity"]("gyro", Gs=Gs)], rate=lambda t, f, Gs=Gs: f @ Gs.T)
    if test["effect"] == "bias_drift":
        d = np.array(p["d_deg_s_per_hour"]) * DEG / 3600.0
        return Cause("bias_drift", "gyro", test["magnitude"], p, (*GYRO_MEANS, "gyro.adev"),
                     lambda seed, d=d: [EFFECTS["bias_drift"]("gyro", d=d)], rate=lambda t, f, d=d: np.multiply.outer(t, d))
    if test["effect"] == "time_offset":
        tau = float(test["magnitude"])
        return Cause("time_offset", "gyro", tau, p, GYRO_MOTION,
                     lambda seed, tau=tau: [EFFECTS["time_offset"]("gyro", tau=tau)])
    if test["effect"] == "accel_scale_nonlinearity":
        K2 = np.array(p["K2"])
        return Cause("accel_scale_nonlinearity", "accel", test["magnitude"], p,
                     ("accel.norm_residual", "accel.norm_scatter"),
                     lambda seed, K2=K2: [EFFECTS["accel_scale_nonlinearity"]("accel", K2=K2)])
    return None
