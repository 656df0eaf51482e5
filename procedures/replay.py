"""Replay the measured schedule in the simulator with the fitted linear model and compare the simulated
session with the measured one per sensor, channel, hold and move (the direct view of "what the
simulation gets wrong"). Both are calibrated with the same fit, so differences are in physical units."""

from __future__ import annotations

import math

import numpy as np

from fixtures.world.model import Environment, SensorModel
from fixtures.world.session_sim import NOMINAL, SessionPlan, simulate_session
from rig.discrepancy.linear import TriadFit
from rig.discrepancy.search import SensorState
from rig.session_data import SessionData


def replay_plan(session: SessionData, st: SensorState) -> SessionPlan:
    holds = ~st.obs.is_move
    schedule = [tuple(map(float, a)) for a in st.obs.angles[holds]]
    hold_s = float(np.median(st.obs.t_end[holds] - st.obs.t_start[holds])) + 1.0 / (session.sample_rate_hz or 100.0)
    speed, accel = 60.0, 120.0
    if session.table_deg is not None:
        rate = np.gradient(session.table_deg, session.t, axis=0)
        speed = float(max(np.percentile(np.abs(rate), 99.5), 1.0))
        acc = np.abs(np.gradient(rate, session.t, axis=0))[session.is_move]
        accel = float(max(np.percentile(acc, 90), 1.0)) if acc.size else accel
    return SessionPlan(schedule=schedule, hold_s=hold_s, speed_dps=speed, accel_dps2=accel,
                       rate_hz=float(session.sample_rate_hz or 100.0))


def sensor_model(st: SensorState, fit: TriadFit) -> SensorModel:
    k = NOMINAL[st.sensor]["scale"]
    per_sample = np.sqrt(np.median(st.obs.sigma[~st.obs.is_move] ** 2 * st.obs.count[~st.obs.is_move][:, None], axis=0))
    return SensorModel(st.sensor, fit.H * k, fit.B / k, per_sample / k)


def environment(session: SessionData, states: list[SensorState]) -> Environment:
    env = Environment(gravity=session.gravity, field_uT=session.field_uT or 50.0)
    mag = [s for s in states if s.sensor == "mag"]
    if mag:
        v = mag[0].fit.v
        env.dip_deg = math.degrees(math.asin(-v[2] / np.linalg.norm(v)))
        env.declination_deg = math.degrees(math.atan2(v[0], v[1]))
    if session.temp_c is not None and np.all(np.isfinite(session.temp_c)):
        env.temperature = lambda t: np.interp(t, session.t, session.temp_c)
    if session.vsupply_v is not None and np.all(np.isfinite(session.vsupply_v)):
        env.supply = lambda t: np.interp(t, session.t, session.vsupply_v)
    return env


def replay_comparison(session: SessionData, states: list[SensorState], extended: dict) -> dict:
    if not states:
        return {"error": "no sensor could be fitted"}
    plan = replay_plan(session, states[0])
    sensors = {st.sensor: sensor_model(st, st.base_fit) for st in states}
    try:
        sim, _ = simulate_session(sensors, plan, env=environment(session, states), seed=1)
    except Exception as exc:   # the replay is a view, never a reason to lose the analysis
        return {"error": f"replay failed: {exc}"}
    out = {"plan": {"orientations": len(plan.schedule), "hold_s": plan.hold_s, "speed_dps": plan.speed_dps,
                    "accel_dps2": plan.accel_dps2}, "sensors": {}}
    for st in states:
        out["sensors"][st.sensor] = compare(session, sim, st)
    return out


def compare(measured: SessionData, sim: SessionData, st: SensorState) -> dict:
    fit = st.base_fit
    hm, hs = measured.holds(st.sensor), sim.holds(st.sensor)
    n = min(len(hm.step), len(hs.step))
    dh = (hm.mean[:n] - hs.mean[:n]) @ fit.H.T
    res = {"holds": {"rms_per_channel": np.sqrt(np.mean(dh ** 2, axis=0)).tolist(),
                     "worst_hold": int(np.argmax(np.linalg.norm(dh, axis=1))) if n else None,
                     "per_hold": dh.tolist()}}
    mm, ms = measured.moves(st.sensor), sim.moves(st.sensor)
    per_move = []
    for a, b in zip(mm, ms):
        m = min(len(a.t), len(b.t))
        d = (a.y[:m] - b.y[:m]) @ fit.H.T
        per_move.append(np.sqrt(np.mean(d ** 2, axis=0)).tolist())
    if per_move:
        pm = np.array(per_move)
        res["moves"] = {"rms_per_channel": np.sqrt(np.mean(pm ** 2, axis=0)).tolist(),
                        "worst_move": int(np.argmax(np.linalg.norm(pm, axis=1))), "per_move": per_move}
    return res
