"""Archived sessions for the lab's tests and benchmarks: simulated by the world model (no buses, fast), written
into real rig session folders through `SessionStore` (one hold with its move per transaction, as the rig does)
and calibrated by the project's pipeline into calibration.json, as a finished session is.

A "golden unit" is one set of sensor models (one rng seed) measured again and again; a rig is a name plus
what its table does to every session on it (effects of `fixtures.world.effects`, e.g. a misaligned axis).
"""

from __future__ import annotations

from datetime import datetime, timedelta

import numpy as np

from fixtures.world.effects import Effect
from fixtures.world.model import random_sensor_models
from fixtures.world.session_sim import SessionPlan, simulate_session
from rig.schedule import plan_orientations
from rig.pipeline import calibrate_session
from rig.pipeline.writing import write_session_calibration
from rig.store import SessionStore


def small_plan(n: int = 12, hold_s: float = 1.0, rate_hz: float = 50.0, seed: int = 1) -> SessionPlan:
    pts = [(o.outer_deg, o.inner_deg) for o in plan_orientations(n, seed=seed)]
    return SessionPlan(schedule=pts, hold_s=hold_s, rate_hz=rate_hz, mag_every=1, speed_dps=90.0, accel_dps2=200.0)


def simulated(unit_seed: int, noise_seed: int, plan: SessionPlan, effects: list[Effect] = ()):
    sensors = random_sensor_models(np.random.default_rng(unit_seed))
    session, _ = simulate_session(sensors, plan, effects=list(effects), seed=noise_seed)
    return session


def write_session(folder, session, *, unit: str, rig: str, operator: str = "tester", start_utc: str,
                  plan: SessionPlan | None = None, finish: bool = True, calibrate: bool = True,
                  status: str | None = None) -> None:
    """`session` (SessionData) as a rig session folder; finished (calibrated, status complete) unless told not."""
    meta = {"unit": {"serial": unit, "board": "bsn"}, "operator": operator, "rig": rig, "start_utc": start_utc,
            "host": "archive", "gravity_mps2": session.gravity, "field_uT": session.field_uT,
            "config": {"geometry": {"outer_axis_world": [1.0, 0.0, 0.0], "inner_axis_fixture": [0.0, 0.0, 1.0]},
                       "schedule": {"rate_hz": session.sample_rate_hz}},
            "schedule": [{"outer_deg": a, "inner_deg": b} for a, b in (plan.schedule if plan else [])],
            "simulated": True, "seed": None}
    with SessionStore.create(folder, meta) as store:
        for move, step, rows in _segments(session):
            arrays = dict(t=session.t[rows], samples={s: y[rows] for s, y in session.raw.items()},
                          q_ref=session.q_ref[rows], table_deg=session.table_deg[rows],
                          temp_c=session.temp_c[rows] if session.temp_c is not None else None,
                          vsupply_v=session.vsupply_v[rows] if session.vsupply_v is not None else None)
            if move:
                store.append_move(step, **arrays)
            else:
                angles = tuple(float(v) for v in session.table_deg[rows][0])
                store.append_hold(step, commanded_deg=angles, measured_deg=angles, **arrays)
        if not finish:
            if status:
                store.set_status(status, "stopped for the test")
                store.update_metadata(end_utc=_later(start_utc, float(session.t[-1])))
            return
        if calibrate:
            result = calibrate_session(store.to_session_data(), settle_s=0.0)
            write_session_calibration(folder, result, gravity=session.gravity, field_uT=session.field_uT,
                                      unit_serial=unit, board="bsn", extra={"verdict": "PASS"})
        store.set_status(status or "complete", "", verdict="PASS" if (status or "complete") == "complete" else "FAIL")
        store.update_metadata(end_utc=_later(start_utc, float(session.t[-1]) + 5.0))   # ended when it would have


def _segments(session):
    """(is_move, step, row slice) of each contiguous run of rows."""
    change = np.flatnonzero((np.diff(session.is_move.astype(int)) != 0) | (np.diff(session.step) != 0)) + 1
    bounds = [0, *change.tolist(), session.t.size]
    for a, b in zip(bounds[:-1], bounds[1:]):
        yield bool(session.is_move[a]), int(session.step[a]), slice(a, b)


def _later(utc: str, seconds: float) -> str:
    when = datetime.fromisoformat(utc.replace("Z", "+00:00")) + timedelta(seconds=seconds)
    return when.isoformat(timespec="milliseconds").replace("+00:00", "Z")
