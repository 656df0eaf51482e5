"""The twin analysis of one recording, end to end: real statistics, the replicas' bands, what falls outside,
the effects that explain it and the bands after the extension (`rig-twin/1`, inside `rig discrepancy`'s report).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import nullcontext

import numpy as np
from scipy.stats import fisher_exact

from procedures.twin.bands import band_chance, bands, default_replicas
from procedures.twin.cause import Cause, quiet_of, terms_of
from procedures.twin.extension import family, outside, propose
from procedures.twin.model import added_rate, centred, heldout_change, model_causes, something_calibrated
from procedures.twin.replay import Replay, poses_alone, reconstruct, twin_view
from procedures.twin.replicas import Background, ReplicaJob, replica_runs
from procedures.twin.vibration import gyro_rate
from rig.calibration.recordings.recording import RecordingCalibration, calibrate_recording
from rig.calibration.numerics.threads import one_blas_thread
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
    alone (which statistics it brings back and which it pushes out); a cause that does not bring back more than it
    pushes out is dropped and the rest run again (`kept_causes`). The held-out refits run beside them."""
    t0 = time.perf_counter()
    calibrate = still_log_calibration if is_still_log(session) else calibrate_recording
    rec = something_calibrated(session, calibrate(session))
    rate = gyro_rate(session, rec)             # the gyro as recorded, even where it is left out below
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

    def replay_for(causes: list[Cause]):
        kept_model = [c for c in causes if c.model]
        return replay if not kept_model else reconstruct(view, rec, added_rate(kept_model))

    with Background(heldout_change, view, rec, model) if heldout else nullcontext() as refits:
        extended = replay_for(model)
        jobs = [ReplicaJob(replay, seeds)]
        if model:
            jobs.append(ReplicaJob(extended, seeds, lambda s: terms_of(model, s)))
        (base, failed), *modelled = replica_runs(jobs)
        before = bands(base)
        off = outside(real, before)
        middle, off_middle = before, off
        if modelled:                   # systematic effects first: the noise is proposed against what they leave
            runs, failed_model = modelled[0]
            middle, failed = bands(runs), failed + failed_model
            off_middle = outside(real, middle)
        proposed = centred(model, before) + propose(view, rec, extended, real, middle, off_middle, replicas, rate)
        causes, dropped, after, failed_after = kept_causes(proposed, replay_for, real, off, base, seeds,
                                                           seeds[:attribution_replicas])
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
        "causes": [_cause_report(c, kept=True) for c in causes],
        "dropped": [_cause_report(c, kept=False) for c in dropped],
        "keep_rule": "a cause is kept where it brings more statistics back inside their band than it pushes out",
        "unexplained": sorted(still),
        "model_tests": tests,
        "heldout_change": change,
        "statistics": {name: {"real": real[name], "before": list(before[name]), "after": list(after.get(name, before[name])),
                              "inside_before": name not in off, "inside_after": name not in still,
                              "family": family(name),
                              "named": sorted({c.effect for c in causes if name in c.brings_back}) or None,
                              "pushed_out_by": sorted({c.effect for c in causes if name in c.pushes_out}) or None}
                       for name in sorted(before) if name in real},
        "calibration": _calibration_summary(rec),
        "not_analysed": not_analysed,
        "seconds": time.perf_counter() - t0,
    }


def _cause_report(c: Cause, *, kept: bool) -> dict:
    """A cause tried as an extension: what it brought back inside their band and pushed out of it (in the last
    round of replicas it ran in), and whether the keep rule kept it."""
    return {"effect": c.effect, "sensor": c.sensor, "magnitude": c.magnitude, "unit": c.unit, "params": c.params,
            "brings_back": sorted(c.brings_back), "pushes_out": sorted(c.pushes_out), "kept": kept}


def kept_causes(causes: list[Cause], replay_for: Callable[[list[Cause]], Replay], real: dict, off: set[str],
                base: list[dict], seeds: list[int], alone: list[int]) -> tuple[list[Cause], list[Cause], dict, int]:
    """The causes the extension keeps, those it dropped, the bands of the replicas with the kept ones and how many
    of those replicas failed. All causes together and each alone are run; a cause that brings no more statistics
    back inside their band than it pushes out of it (`attribute`, against the plain twin's replicas `base`) is
    dropped, and the rest run again: an accelerometer's disturbance taken for a hand's turn had pushed its norm
    scatter out on every recording of a set while bringing its spreads in no better than a vibration of its own
    spectrum does."""
    before = bands(base)
    dropped: list[Cause] = []
    after, failed = before, 0
    while causes:
        extended = replay_for(causes)
        (runs, failed), *each = replica_runs(
            [ReplicaJob(extended, seeds, lambda s, together=tuple(causes): terms_of(list(together), s),
                        quiet_of(causes))]
            + [ReplicaJob(extended, alone, lambda s, c=c: terms_of([c], s), quiet_of([c])) for c in causes])
        after = bands(runs)
        attribute(causes, [r for r, _ in each], real, off, outside(real, after), base, runs)
        losing = [c for c in causes if len(c.brings_back) <= len(c.pushes_out)]
        if not losing:
            break
        dropped += losing
        causes = [c for c in causes if c not in losing]
    if not causes:
        after, failed = before, 0
    return causes, dropped, after, failed


def attribute(causes: list[Cause], runs_alone: list[list[dict]], real: dict, off: set[str], still: set[str],
              base: list[dict], runs: list[dict]) -> None:
    """Which cause alone (its replicas `runs_alone`) brings each statistic back, and which pushes each out;
    statistics only all of them together bring back or push out are given to every cause that governs them, and
    those pushed out that none governs, to every cause.

    A statistic is pushed out where it is inside the plain twin's band (its replicas `base`), outside the
    extension's (`runs`), and the extension's replicas lie beyond the recording's value less often than the plain
    twin's by more than chance (`moved_past`): an extension that changes a calibration a little moves a statistic
    at the edge of its band out as often as in, which is no harm done (a delay of the gyro put into the twin moved
    a value step 1 % of its band's width, out, and was dropped for it)."""
    back = off - still
    out = {name for name in still - off if moved_past(real[name], [r.get(name) for r in base],
                                                      [r.get(name) for r in runs])}
    alone_out = [outside(real, bands(r)) for r in runs_alone]
    for cause, outs in zip(causes, alone_out):
        cause.brings_back = sorted(back - outs)
        cause.pushes_out = sorted(out & outs)
    named = {n for c in causes for n in c.brings_back}
    for name in back - named:
        for cause in causes:
            if family(name) in cause.governs:
                cause.brings_back.append(name)
    blamed = {n for c in causes for n in c.pushes_out}
    for name in out - blamed:
        governing = [c for c in causes if family(name) in c.governs]
        for cause in governing or causes:
            cause.pushes_out.append(name)


def moved_past(value: float, before: list, after: list, alpha: float = 0.05) -> bool:
    """Whether the replicas `after` lie beyond `value`, on the side it now falls out of their band, less often than
    those `before` by more than chance: Fisher's exact test, one-sided at alpha."""
    b = np.array([x for x in before if x is not None and np.isfinite(x)])
    a = np.array([x for x in after if x is not None and np.isfinite(x)])
    if not len(a) or not len(b):
        return False
    above = np.median(a) > value                     # the band moved up past the value: beyond is below it
    k_a, k_b = (int(np.sum(a < value)), int(np.sum(b < value))) if above else (int(np.sum(a > value)),
                                                                              int(np.sum(b > value)))
    return bool(fisher_exact([[k_a, len(a) - k_a], [k_b, len(b) - k_b]], alternative="less")[1] < alpha)


def _calibration_summary(rec: RecordingCalibration) -> dict:
    return {name: {"method": cal.method, "B": np.asarray(cal.B).tolist(), "H": np.asarray(cal.H).tolist(),
                   "residual_rms": float(cal.residual_rms)} for name, cal in rec.sensors.items()}
