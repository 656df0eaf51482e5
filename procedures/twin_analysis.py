"""The twin analysis of one recording, end to end: real statistics, the replicas' bands, what falls outside,
the effects that explain it and the bands after the extension (`rig-twin/1`, inside `rig discrepancy`'s report).
"""

from __future__ import annotations

import time
from contextlib import nullcontext

import numpy as np

from procedures.twin_bands import band_chance, bands, default_replicas
from procedures.twin_cause import Cause
from procedures.twin_extension import family, outside, propose
from procedures.twin_model import added_rate, heldout_change, model_causes
from procedures.twin_replay import poses_alone, reconstruct, twin_view
from procedures.twin_replicas import Background, ReplicaJob, replica_runs
from rig.calibration.recording import RecordingCalibration, calibrate_recording
from rig.calibration.threads import one_blas_thread
from rig.noise.statistics import recording_statistics
from rig.noise.still_log import is_still_log, still_log_calibration
from rig.session_data import SessionData

SCHEMA = "rig-twin/1"


def analyse_twin(session: SessionData, *, replicas: int | None = None, attribution_replicas: int = 10,
                 seed: int = 0, heldout: bool = False) -> dict:
    """Every statistic of the recording against its twin before and after the extension, as a JSON-able dict;
    `replicas`: None for `default_replicas` of the recording's rows."""
    replicas = replicas or default_replicas(len(session.t))
    with one_blas_thread():
        return _analyse_twin(session, replicas=replicas, attribution_replicas=attribution_replicas, seed=seed,
                             heldout=heldout)


def _analyse_twin(session: SessionData, *, replicas: int, attribution_replicas: int, seed: int,
                  heldout: bool) -> dict:
    """Two rounds of replicas, each in one pool: the simulator as it is beside the model effects the recording's
    own tests find (the noise is proposed against what those leave), then all causes together beside each cause
    alone (which statistics it brings back). The held-out refits run beside them."""
    t0 = time.perf_counter()
    calibrate = still_log_calibration if is_still_log(session) else calibrate_recording
    rec = calibrate(session)
    view = twin_view(session, rec)
    not_analysed = dict(rec.refused)           # a sensor that cannot be calibrated (the gyro of hand-held poses)
    if not_analysed:
        view = poses_alone(view, rec, set(not_analysed))
    if view is not session:                    # the poses it found, now named; or a sensor left out
        rec = calibrate(view)
    real = recording_statistics(view, rec)
    replay = reconstruct(view, rec)
    seeds = list(range(seed * 10_000, seed * 10_000 + replicas))
    model, tests = model_causes(view, rec)
    with Background(heldout_change, view, rec, model) if heldout else nullcontext() as refits:
        extended = replay if not model else reconstruct(view, rec, added_rate(model))
        jobs = [ReplicaJob(replay, seeds)]
        if model:
            jobs.append(ReplicaJob(extended, seeds, lambda s: [e for c in model for e in c.make(s)]))
        (base, failed), *modelled = replica_runs(jobs)
        before = bands(base)
        off = outside(real, before)
        middle, off_middle = before, off
        if modelled:                   # systematic effects first: the noise is proposed against what they leave
            runs, failed_model = modelled[0]
            middle, failed = bands(runs), failed + failed_model
            off_middle = outside(real, middle)
        causes = model + propose(view, rec, extended, real, middle, off_middle, replicas)
        after, failed_after = before, 0
        if causes:
            quiet = tuple({q for c in causes for q in c.quiet})
            alone = seeds[:attribution_replicas]
            (runs, failed_after), *each = replica_runs(
                [ReplicaJob(extended, seeds, lambda s: [e for c in causes for e in c.make(s)], quiet)]
                + [ReplicaJob(extended, alone, c.make, c.quiet) for c in causes])
            after = bands(runs)
            _attribute(causes, [r for r, _ in each], real, off, outside(real, after))
        change = refits.result() if heldout else None
    still = outside(real, after)
    return {
        "schema": SCHEMA, "session": session.source, "replicas": replicas, "replicas_failed": failed + failed_after,
        "replayed": ("one pose held (a still log), in the units it was recorded in"
                     if calibrate is still_log_calibration else "its poses alone" if not_analysed
                     else "its poses and motions"),
        "band": "1-99 % of the replicas, as order statistics (the k-th smallest to the k-th largest)",
        "band_chance": band_chance(replicas),          # of a statistic the twin gets right falling outside it
        "summary": {"statistics": len(before), "inside_before": len(before) - len(off),
                    "inside_after": len(after) - len(still), "outside_before": sorted(off),
                    "outside_after": sorted(still)},
        "causes": [{"effect": c.effect, "sensor": c.sensor, "magnitude": c.magnitude, "unit": c.unit,
                    "params": c.params, "brings_back": sorted(c.brings_back)} for c in causes],
        "unexplained": sorted(still),
        "model_tests": tests,
        "heldout_change": change,
        "statistics": {name: {"real": real[name], "before": list(before[name]), "after": list(after.get(name, before[name])),
                              "inside_before": name not in off, "inside_after": name not in still,
                              "family": family(name),
                              "named": sorted({c.effect for c in causes if name in c.brings_back}) or None}
                       for name in sorted(before) if name in real},
        "calibration": _calibration_summary(rec),
        "not_analysed": not_analysed,
        "seconds": time.perf_counter() - t0,
    }


def _attribute(causes: list[Cause], runs_alone: list[list[dict]], real: dict, off: set[str], still: set[str]
               ) -> None:
    """Which cause alone (its replicas `runs_alone`) brings each statistic back; statistics only all of them
    together bring back are given to every cause that governs them."""
    back = off - still
    for cause, runs in zip(causes, runs_alone):
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
