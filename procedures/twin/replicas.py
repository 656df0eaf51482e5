"""A twin's replicas: one replica is the world (`fixtures.world`) sensing the replayed motion
(`procedures.twin.replay`) with `y = inv(H) u + B` of the recording's own calibration, white noise of the
recording's own size in every pose (`procedures.twin.noise`), counts rounded where the recording is in counts and
values in physical units written as the recording's were (`procedures.twin.printed`);
effects of the vocabulary can be added to it (`effects`), which is how the extension is measured. Replicas are
independent, so many run at once in forked worker processes (`procedures.fork_pool`, which leave stop signals to
this one), each calibrated and reduced to its statistics there;
the held-out refits run beside them in a process of their own (`Background`). The workers find their functions
(`_one_replica`, `_run_background`) and the work they share (`_JOBS`, `_BACKGROUND`) in this module."""

from __future__ import annotations

import os
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass

import numpy as np

from fixtures.world.model import SensorModel, World
from procedures.fork_pool import ForkPool, fork_available
from procedures.twin.draws import drawn_level
from procedures.twin.replay import HandAcceleration, Replay
from rig.errors import CalibrationError
from rig.io.recording import recording_session
from rig.session_data import SessionData


def replica(replay: Replay, seed: int, effects: Iterable = (), quiet: Collection[str] = ()) -> SessionData:
    """One simulated recording of the twin (noise trial `seed`); the `quiet` sensors' white noise is left to an
    effect that replaces it."""
    order = sorted(replay.sensors)
    sensors = {n: SensorModel(m.kind, m.H, m.B, np.zeros(3) if n in quiet
                              else drawn_level(m.noise_std, (replay.noise_dof or {}).get(n), seed, order.index(n)))
               for n, m in replay.sensors.items()}
    effects = list(effects)
    if replay.hand is not None and "accel" in sensors:
        effects.append(HandAcceleration("accel", t=replay.t, a=replay.hand))
    world = World(None, sensors, env=replay.env, effects=effects, seed=seed, attitude=replay.attitude)
    raw = {}
    for name in replay.sensors:
        y = world.sense(name, replay.t)
        if name in (replay.grid or {}):
            step, origin = replay.grid[name]
            on = step > 0
            y[:, on] = np.round((y[:, on] - origin[on]) / step[on]) * step[on] + origin[on]
            if name in (replay.printed or {}) and not on.all():
                rest = y[:, ~on]
                replay.printed[name].apply(rest)
                y[:, ~on] = rest
        elif replay.units[name] == "counts":
            np.round(y, out=y)
        elif name in (replay.printed or {}):
            replay.printed[name].apply(y)
        y[replay.missing[name]] = np.nan
        raw[name] = y
    return recording_session(replay.t, raw, units=replay.units, gravity=replay.env.gravity,
                             field_uT=replay.env.field_uT if "mag" in raw else None, segments=replay.segments,
                             sample_rate_hz=replay.rate_hz, source=f"twin of {replay.source}, trial {seed}")


@dataclass
class ReplicaJob:
    """Replicas of one replay: the noise trials `seeds`, each with the effects `effects_for(seed)`; the `quiet`
    sensors' white noise is left to an effect that replaces it."""

    replay: Replay
    seeds: list[int]
    effects_for: Callable[[int], list] = lambda seed: []
    quiet: tuple[str, ...] = ()


def replica_statistics(replay: Replay, seeds: Iterable[int], effects_for: Callable[[int], Iterable] = lambda seed: (),
                       quiet: Iterable[str] = (), workers: int | None = None) -> tuple[list[dict], int]:
    """Statistics of the replicas of `seeds` (each with the effects `effects_for(seed)`); and how many replicas
    could not be calibrated (those are left out of the band, and counted)."""
    return replica_runs([ReplicaJob(replay, list(seeds), effects_for, tuple(quiet))], workers)[0]


def replica_runs(jobs: list[ReplicaJob], workers: int | None = None) -> list[tuple[list[dict], int]]:
    """replica_statistics of several jobs at once, in one pool: replicas are independent, so every replica of
    every job is one task for the next free core (forked workers inherit the replays; nothing is pickled but
    indices and statistics), and no core waits for a job's last replica while another job has work. A replica's
    statistics depend on its replay, seed and effects only, never on which worker ran it or when."""
    tasks = [(j, seed) for j, job in enumerate(jobs) for seed in job.seeds]
    workers = min(workers or os.cpu_count() or 1, len(tasks)) if tasks else 1
    global _JOBS
    _JOBS = jobs
    try:
        if workers > 1 and fork_available():
            with ForkPool(workers, "the twin's replicas") as pool:
                results = pool.map(_one_replica, tasks)
        else:
            results = [_one_replica(task) for task in tasks]
    finally:
        _JOBS = None
    out = []
    for j in range(len(jobs)):
        mine = [r for (k, _), r in zip(tasks, results) if k == j]
        kept = [r for r in mine if r is not None]
        out.append((kept, len(mine) - len(kept)))
    return out


_JOBS: list[ReplicaJob] | None = None


def _one_replica(task: tuple[int, int]) -> dict | None:
    j, seed = task
    job = _JOBS[j]
    rep = replica(job.replay, seed, job.effects_for(seed), job.quiet)
    try:
        return job.replay.statistics(rep, job.replay.calibrate(rep))
    except CalibrationError:
        return None


class Background:
    """`fn(*args)` run in a forked process while this one goes on (the held-out refits beside the replicas: a
    third process on two cores keeps both busy through the pools' last tasks and the steps between them);
    `result()` waits for it. The arguments reach the child by the fork, not pickled. Where the child fails, or
    there is no fork, `result()` runs `fn` here, so an error is raised as it would have been without this."""

    def __init__(self, fn: Callable, *args) -> None:
        global _BACKGROUND
        self.fn, self.args, self._workers, self._async = fn, args, None, None
        if (os.cpu_count() or 1) > 1 and fork_available():
            _BACKGROUND = (fn, args)
            try:
                self._workers = ForkPool(1, "the held-out refits")
                self._async = self._workers.submit(_run_background)
            finally:
                _BACKGROUND = None

    def result(self) -> object:
        if self._async is not None:
            ok, value = self._workers.result(self._async)
            self.close()
            if ok:
                return value
        return self.fn(*self.args)

    def close(self, abandon: bool = False) -> None:
        if self._workers is not None:
            self._workers.close(abandon)
            self._workers, self._async = None, None

    def __enter__(self) -> "Background":
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(abandon=exc_type is not None)


_BACKGROUND = None


def _run_background() -> tuple[bool, object]:
    fn, args = _BACKGROUND
    try:
        return True, fn(*args)
    except Exception:          # raised again where it belongs: result() runs fn in the parent
        return False, None
