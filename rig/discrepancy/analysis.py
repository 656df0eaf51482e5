"""`analyze(session)`: what the linear model misses, named in the `effects.md` vocabulary, as a
`rig-discrepancy/1` report.

The session's truth (a simulated session carries it in `meta["truth"]`) is never read: the analysis
sees raw counts, the reference attitude, time, temperature and supply only.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from rig.calibration.turntable.reference_convention import refuse_conjugated_reference
from rig.discrepancy.candidates import CANDIDATES, library
from rig.discrepancy.linear import TriadFit, fit_baseline
from rig.discrepancy.observations import observations
from rig.discrepancy.plots import write_plots
from rig.discrepancy.search import (ALPHA, DBIC_MAX, GAIN_MIN, WILCOXON_MAX, Accepted, SensorState,
                                    calibrate_noise_scale, extended_fit, stepwise)
from rig.discrepancy.stats import heldout_gate, nested_test
from rig.effects import effect as vocabulary_entry
from rig.errors import CalibrationError
from rig.session_data import SessionData
from rig.units import SENSOR_UNITS

SCHEMA = "rig-discrepancy/1"
SENSORS = ("accel", "gyro", "mag")
MC_DRAWS = 2000
UNIDENTIFIABLE = 0.05


def is_tumble_table(session: SessionData) -> bool:
    table = session.meta.get("table") or {}
    return (list(map(float, table.get("outer_axis_world", [1, 0, 0]))) == [1.0, 0.0, 0.0]
            and list(map(float, table.get("inner_axis_fixture", [0, 0, 1]))) == [0.0, 0.0, 1.0])


def build_states(session: SessionData) -> tuple[list[SensorState], list[str]]:
    states, skipped = [], []
    tumble = is_tumble_table(session)
    if not tumble:
        geometry = [name for name, (_, needs) in CANDIDATES.items() if "tumble_table" in needs]
        skipped.append(f"table geometry {session.meta.get('table')} is not the tumble table of conventions.md: "
                       f"{' and '.join(geometry)} not tested")
    for sensor in SENSORS:
        if sensor not in session.raw:
            continue
        norm = {"accel": session.gravity, "mag": session.field_uT, "gyro": None}[sensor]
        if sensor == "mag" and norm is None:
            skipped.append("mag: no field magnitude (field_uT) in the session")
            continue
        try:
            obs = observations(session, sensor)
            fit = fit_baseline(obs, sensor, norm)
        except (CalibrationError, ValueError) as exc:
            skipped.append(f"{sensor}: {exc}")
            continue
        st = SensorState(sensor, obs, fit, library(sensor, obs, tumble_table=tumble))
        calibrate_noise_scale(st)
        states.append(st)
    return states, skipped


def analyze(session: SessionData, *, replay: Callable[..., dict] | None = None, plots_dir=None) -> dict:
    """Fit, test every candidate, accept what passes, extend and refit; the report as a dict.
    With `plots_dir`, residual-vs-covariate plots before and after each finding are written there."""
    t0 = time.perf_counter()
    if "accel" in session.raw:
        refuse_conjugated_reference(session, session.holds("accel"))
    states, skipped = build_states(session)
    first = stepwise(states)
    findings, changes, extended = [], {}, {}
    for st in states:
        ext = extended_fit(st)
        st.fit = ext
        extended[st.sensor] = ext
        changes[st.sensor] = parameter_change(st.base_fit, ext)
        for i, acc in enumerate(st.accepted):
            findings.append(finding(st, i, acc))
    findings = merge_rig_findings(findings)
    accepted_keys = {(a.cand.effect, st.sensor) for st in states for a in st.accepted}
    candidates = [{"effect": t.cand.effect, "sensor": reported_sensor(t.cand),
                   "tested_on": t.state.sensor,
                   "score": float(-np.log10(max(t.p_holm, 1e-300))), "p_holm": float(t.p_holm),
                   "delta_bic": float(t.test.dbic),
                   "heldout_gain": None if t.gate is None else float(t.gate.gain),
                   "significant": bool(t.passes or (t.cand.effect, t.state.sensor) in accepted_keys),
                   "identifiable_fraction": t.identifiable,
                   **({"implausible": t.implausible} if t.passes_tests and t.implausible else {})}
                  for t in first]
    report = {
        "schema": SCHEMA,
        "session": str(session.meta.get("session", session.source)),
        "findings": findings,
        "candidates": candidates,
        "baseline": {st.sensor: {"B": st.base_fit.B.tolist(), "H": st.base_fit.H.tolist(),
                                 "reference_world": None if st.base_fit.v is None else st.base_fit.v.tolist(),
                                 "rows": {"holds": int((~st.obs.is_move).sum()), "move_windows": int(st.obs.is_move.sum())}}
                     for st in states},
        "calibration_change": changes,
        "rule": {"alpha_holm": ALPHA, "delta_bic_max": DBIC_MAX, "heldout_gain_min": GAIN_MIN,
                 "wilcoxon_p_max": WILCOXON_MAX, "noise_model": "AR(1) FGLS (Prais-Winsten) per residual channel",
                 "heldout": "leave-one-orientation-out"},
        "skipped": skipped,
        "unidentifiable": [f"{t.cand.effect} on {t.state.sensor}: the linear model (B, H, reference direction) absorbs "
                           f"{100 * (1 - t.identifiable):.0f} % of its signature in this schedule, so the data cannot "
                           "tell it from a constant bias, scale/soft iron or mounting"
                           for t in first if t.identifiable < UNIDENTIFIABLE],
    }
    if replay is not None:
        report["replay"] = replay(session, states, extended)
    if plots_dir is not None:
        report["plots"] = write_plots(states, plots_dir)
    report["analysis_seconds"] = time.perf_counter() - t0
    return report


def reported_sensor(cand) -> str:
    """The sensor a finding is reported on: the rig itself for a table error, whichever triad saw it."""
    return vocabulary_entry(cand.effect).reported_sensor(cand.sensor)


def parameter_change(base: TriadFit, ext: TriadFit) -> dict:
    dH = ext.H - base.H
    return {"B_before": base.B.tolist(), "B_after": ext.B.tolist(), "H_before": base.H.tolist(),
            "H_after": ext.H.tolist(), "dB_counts": (ext.B - base.B).tolist(),
            "dH_relative_max": float(np.abs(dH).max() / np.abs(base.H).max())}


def _conditional(st: SensorState, i: int):
    """Test and held-out gain of accepted effect i given all the other accepted effects."""
    acc = st.accepted[i]
    others, st.accepted = st.accepted, [a for j, a in enumerate(st.accepted) if j != i]
    try:
        d = st.design()
        Z = st.weighted(st.columns(acc.cand, acc.scan_value))
        return nested_test(d, Z, acc.cand.labels), heldout_gate(d, Z)
    finally:
        st.accepted = others


def finding(st: SensorState, i: int, acc: Accepted) -> dict:
    test, gate = _conditional(st, i)
    mag, unc = magnitude_with_uncertainty(acc.cand, test.coef, test.cov)
    kind = gate.kind
    evidence = {"p_holm": acc.p_holm, "p_group": test.p_group, "p_axes": test.p_axes, "delta_bic": test.dbic,
                "ar1_rho": {str(k): v for k, v in test.rho.items()}, "heldout_gain": gate.gain,
                "heldout_wilcoxon_p": gate.p_wilcoxon, "heldout_groups": gate.n_groups,
                "heldout_rows": kind, "heldout_rms_by_kind_before": gate.phys_before,
                "heldout_rms_by_kind_after": gate.phys_after, "params": acc.cand.params(test.coef),
                "model": acc.cand.note}
    if acc.scan_value is not None:
        evidence["t_flip_s"] = acc.scan_value
    out = {"effect": acc.cand.effect, "sensor": reported_sensor(acc.cand),
           "magnitude": mag, "unit": acc.cand.unit, "uncertainty": unc,
           "heldout_rms_before": gate.phys_before[kind], "heldout_rms_after": gate.phys_after[kind],
           "heldout_unit": SENSOR_UNITS[st.sensor], "evidence": evidence}
    if acc.ambiguous_with:
        out["ambiguous_with"] = sorted(set(acc.ambiguous_with))
    return out


def magnitude_with_uncertainty(cand, coef: np.ndarray, cov: np.ndarray) -> tuple[float, float]:
    """Magnitude of the fitted coefficients; its standard deviation over draws from N(coef, cov)."""
    mag = cand.magnitude(coef)
    rng = np.random.default_rng(12345)
    cov = 0.5 * (cov + cov.T)
    draws = rng.multivariate_normal(coef, cov, size=MC_DRAWS, method="eigh")
    mags = np.array([cand.magnitude(c) for c in draws])
    return float(mag), float(np.std(mags))


def merge_rig_findings(findings: list[dict]) -> list[dict]:
    """A table geometry error is one finding of the rig, however many sensors saw it: keep the most
    precise estimate and list every sensor's."""
    rig = [f for f in findings if f["sensor"] == "rig"]
    if len(rig) <= 1:
        return findings
    best = min(rig, key=lambda f: f["uncertainty"] / max(f["magnitude"], 1e-12))
    best = dict(best, evidence=dict(best["evidence"], seen_by={f["evidence"]["params"]["seen_by"]: f["magnitude"]
                                                               for f in rig}))
    return [f for f in findings if f["sensor"] != "rig"] + [best]
