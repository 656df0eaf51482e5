"""The twin of a recording without a gyroscope (a magnetometer alone, an accelerometer alone, or both): the
recording replayed at the attitudes its own directions give (`procedures.twin.directions`), its replicas
calibrated as it was and compared on the statistics of the sensors it holds (`procedures.twin.field_statistics`).
The report is `rig-twin/1`, as `procedures.twin.analysis` writes it for a recording with a gyroscope; the
recording tests of the poses (the gyro's g-sensitivity, its delay, its drift) and the noise effects read off held
poses need what such a recording lacks and are not run; the cause a recording without a gyroscope can show alone,
a magnetometer's offset that steps (`procedures.twin.offset_flip`), is proposed where its norm shows one."""

from __future__ import annotations

import time

import numpy as np

from fixtures.world.model import SensorModel
from procedures.twin.analysis import SCHEMA, kept_causes
from procedures.twin.bands import band_chance, bands, default_replicas
from procedures.twin.cause import Cause
from procedures.twin.directions import reconstruct_from_directions
from procedures.twin.extension import family, outside
from procedures.twin.field_statistics import field_statistics, reference_norm
from procedures.twin.offset_flip import OffsetFlip, offset_flip
from procedures.twin.replay import Replay
from procedures.twin.model import something_calibrated
from procedures.twin.replicas import ReplicaJob, replica_runs
from rig.calibration.recordings.recording import calibrate_recording
from rig.calibration.numerics.threads import one_blas_thread
from rig.errors import CalibrationError
from rig.session_data import SessionData, filled

MIN_CALIBRATED = 0.5       # share of the replicas that must calibrate for their band to be read


def analyse_gyroless_twin(session: SessionData, *, replicas: int | None = None, attribution_replicas: int = 10,
                          seed: int = 0) -> dict:
    """Every statistic of the recording against its twin before and after the extension, as a JSON-able dict
    (`rig-twin/1`); `replicas`: None for `default_replicas` of the recording's rows."""
    replicas = replicas or default_replicas(len(session.t))
    with one_blas_thread():
        return _analyse(session, replicas, attribution_replicas, seed)


def _analyse(session: SessionData, replicas: int, attribution_replicas: int, seed: int) -> dict:
    t0 = time.perf_counter()
    # the poses it finds are not named: a turn inside one is not refused
    rec = something_calibrated(session, calibrate_recording(session))
    real = field_statistics(session, rec)
    replay = reconstruct_from_directions(session, rec, field_statistics)
    seeds = list(range(seed * 10_000, seed * 10_000 + replicas))
    [(base, failed)] = replica_runs([ReplicaJob(replay, seeds)])
    if len(base) < MIN_CALIBRATED * replicas:
        raise CalibrationError(f"{failed} of the twin's {replicas} replicas could not be calibrated "
                               "as the recording was; their band would say nothing")
    before = bands(base)
    off = outside(real, before)
    proposed, flipped, flip_cause = [], replay, None
    if "mag" in rec.sensors and any(family(name).startswith("mag.") for name in off):
        norm = reference_norm(session, "mag") or float(np.median(np.linalg.norm(
            rec.sensors["mag"].apply(filled(session.raw["mag"])), axis=1)))
        flip = offset_flip(session, rec, norm, calibrate_recording)
        if flip is not None:
            proposed.append(flip_cause := flip.cause)
            flipped = replay_without_step(replay, flip)

    def replay_for(causes: list[Cause]) -> Replay:
        return flipped if any(c is flip_cause for c in causes) else replay

    causes, dropped, after, failed_after = kept_causes(proposed, replay_for, real, off, base, seeds,
                                                       seeds[:attribution_replicas])
    still = outside(real, after)
    sensors = [s for s in ("accel", "mag") if s in rec.sensors]
    return {
        "schema": SCHEMA, "session": session.source, "replicas": replicas, "replicas_failed": failed + failed_after,
        "replayed": "every sample, at the attitude its " + " and ".join(
            {"accel": "gravity", "mag": "field"}[s] for s in sensors) + " direction gives (no gyroscope)",
        "band": "1-99 % of the replicas, as order statistics (the k-th smallest to the k-th largest)",
        "band_chance": band_chance(replicas),
        "summary": {"statistics": len(before), "inside_before": len(before) - len(off),
                    "inside_after": len(after) - len(still), "outside_before": sorted(off),
                    "outside_after": sorted(still)},
        "causes": [_cause_report(c) for c in causes],
        "dropped": [_cause_report(c) for c in dropped],
        "keep_rule": "a cause is kept where it brings more statistics back inside their band than it pushes out",
        "unexplained": sorted(still),
        "model_tests": [],
        "heldout_change": None,
        "statistics": {name: {"real": real[name], "before": list(before[name]),
                              "after": list(after.get(name, before[name])),
                              "inside_before": name not in off, "inside_after": name not in still,
                              "family": family(name),
                              "named": sorted({c.effect for c in causes if name in c.brings_back}) or None,
                              "pushed_out_by": sorted({c.effect for c in causes if name in c.pushes_out}) or None}
                       for name in sorted(before) if name in real},
        "calibration": {name: {"method": cal.method, "B": np.asarray(cal.B).tolist(), "H": np.asarray(cal.H).tolist(),
                               "residual_rms": float(cal.residual_rms)} for name, cal in rec.sensors.items()},
        "not_analysed": {},
        "seconds": time.perf_counter() - t0,
    }


def replay_without_step(replay: Replay, flip: OffsetFlip) -> Replay:
    """The recording replayed from its samples with the step taken out, calibrated again (the cause puts the step
    back in every replica): the plain replay's directions and calibration are the compromise the step forced. The
    noise, the grid and the gaps stay the recording's own."""
    out = reconstruct_from_directions(flip.session, flip.rec, replay.statistics)
    out.sensors = {s: SensorModel(s, m.H, m.B, replay.sensors[s].noise_std) for s, m in out.sensors.items()}
    out.grid, out.printed, out.missing = replay.grid, replay.printed, replay.missing
    return out


def _cause_report(c) -> dict:
    return {"effect": c.effect, "sensor": c.sensor, "magnitude": c.magnitude, "unit": c.unit, "params": c.params,
            "brings_back": sorted(c.brings_back), "pushes_out": sorted(c.pushes_out)}
