"""The twin analysis of one recording, end to end: real statistics, the replicas' bands, what falls outside,
the effects that explain it and the bands after the extension (`rig-twin/1`, inside `rig discrepancy`'s report).
"""

from __future__ import annotations

import time

import numpy as np

from procedures.twin import bands, reconstruct, replica_statistics, twin_view
from procedures.twin_extension import Cause, family, outside, propose
from procedures.twin_model import added_rate, heldout_change, model_causes
from rig.calibration.recording import RecordingCalibration, calibrate_recording
from rig.noise.statistics import recording_statistics
from rig.session_data import SessionData

SCHEMA = "rig-twin/1"


def analyse_twin(session: SessionData, *, replicas: int = 40, attribution_replicas: int = 10,
                 seed: int = 0, heldout: bool = False) -> dict:
    """Every statistic of the recording against its twin before and after the extension, as a JSON-able dict."""
    t0 = time.perf_counter()
    rec = calibrate_recording(session)
    view = twin_view(session, rec)
    rec = calibrate_recording(view)
    real = recording_statistics(view, rec)
    replay = reconstruct(view, rec)
    seeds = range(seed * 10_000, seed * 10_000 + replicas)
    base, failed = replica_statistics(replay, seeds)
    before = bands(base)
    off = outside(real, before)
    model, tests = model_causes(view, rec)
    extended = replay if not model else reconstruct(view, rec, added_rate(model))
    middle, off_middle = before, off
    if model:                          # systematic effects first: the noise is proposed against what they leave
        runs, failed_model = replica_statistics(extended, seeds, lambda s: [e for c in model for e in c.make(s)])
        middle, failed = bands(runs), failed + failed_model
        off_middle = outside(real, middle)
    causes = model + propose(view, rec, extended, real, middle, off_middle, replicas)
    after, failed_after = before, 0
    if causes:
        quiet = tuple({q for c in causes for q in c.quiet})
        runs, failed_after = replica_statistics(extended, seeds, lambda s: [e for c in causes for e in c.make(s)],
                                                quiet)
        after = bands(runs)
        _attribute(extended, causes, real, off, outside(real, after), seeds[:attribution_replicas])
    still = outside(real, after)
    return {
        "schema": SCHEMA, "session": session.source, "replicas": replicas, "replicas_failed": failed + failed_after,
        "band": "1-99 % of the replicas",
        "summary": {"statistics": len(before), "inside_before": len(before) - len(off),
                    "inside_after": len(after) - len(still), "outside_before": sorted(off),
                    "outside_after": sorted(still)},
        "causes": [{"effect": c.effect, "sensor": c.sensor, "magnitude": c.magnitude, "unit": c.unit,
                    "params": c.params, "brings_back": sorted(c.brings_back)} for c in causes],
        "unexplained": sorted(still),
        "model_tests": tests,
        "heldout_change": heldout_change(view, rec, model) if heldout else None,
        "statistics": {name: {"real": real[name], "before": list(before[name]), "after": list(after.get(name, before[name])),
                              "inside_before": name not in off, "inside_after": name not in still,
                              "family": family(name),
                              "named": sorted({c.effect for c in causes if name in c.brings_back}) or None}
                       for name in sorted(before) if name in real},
        "calibration": _calibration_summary(rec),
        "seconds": time.perf_counter() - t0,
    }


def _attribute(replay, causes: list[Cause], real: dict, off: set[str], still: set[str], seeds) -> None:
    """Which cause alone brings each statistic back; statistics only all of them together bring back are given to
    every cause that governs them."""
    back = off - still
    for cause in causes:
        runs, _ = replica_statistics(replay, seeds, cause.make, cause.quiet)
        alone = back - outside(real, bands(runs))
        cause.brings_back = sorted(alone)
    named = {n for c in causes for n in c.brings_back}
    for name in back - named:
        for cause in causes:
            if family(name) in cause.governs:
                cause.brings_back.append(name)


def _calibration_summary(rec: RecordingCalibration) -> dict:
    return {name: {"method": cal.method, "B": np.asarray(cal.B).tolist(), "H": np.asarray(cal.H).tolist(),
                   "residual_rms": float(cal.residual_rms)} for name, cal in rec.sensors.items()}
