"""Thermal hysteresis and thermal lag named and sized from the steps of a thermal session.

Four fits of the same steps (sweeps.py): the curves alone (M0), with the sweep offset h (MH), with the lag tau
(ML), with both (MHL). Each cause is tested in the presence of the other, by the likelihood ratio of the nested
fits: Delta chi2 = chi2(without) - chi2(MHL) on q degrees of freedom (6 for h, 1 for tau), against chi2_q where the
steps scatter as their covariances say, and as q F(q, dof) with the chi-square divided by MHL's reduced
chi-square where they scatter more (the stated deviations too small by a common factor). Hysteresis is a
constant offset by direction, one per term (6), lag one tau whose offset on each term is the rate times that
term's slope: with rates that differ between steps the two differ and each test sees its own cause. Where they do
not (`lag_inflation` large: the lag column is nearly a sweep offset, as on a session swept at one rate over
straight curves) the lag cannot be told from a part of the hysteresis and is not named; the hysteresis still can
be, where no lag explains the offsets across the six terms (a lag's offsets follow the terms' slopes, a
hysteresis's need not), and is then sized from MH, the lag's share of it unknown. A direction-dependent error
that neither test attributes (M0 against MHL) is reported as not distinguishable, with both readings sized.

False alarms: the two conditional tests at alpha/4 each and the joint one at alpha/2, so that a clean unit is
called anything with probability at most alpha (Bonferroni) per sensor.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from rig.discrepancy.thermal.sweeps import SweepData, SweepFit, SweepModel, SweptStep, sweep_data
from rig.effects import THERMAL_HYSTERESIS, THERMAL_LAG, unit_for
from rig.units import REPORT_UNITS

ALPHA = 0.01
INDISTINCT = 5.0        # lag_inflation above this: the lag's deviation 5x what it is alone, R^2 > 0.96


@dataclass
class ThermalCause:
    """One cause named (or one reading of an undistinguished error): `magnitude` in the vocabulary's unit with its
    standard deviation `uncertainty`, the p-value of its test and its per-axis parameters."""

    effect: str
    sensor: str
    magnitude: float
    uncertainty: float
    unit: str
    p: float
    params: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"effect": self.effect, "sensor": self.sensor, "magnitude": self.magnitude,
                "uncertainty": self.uncertainty, "unit": self.unit, "p": self.p, "params": self.params}


@dataclass
class ThermalCauses:
    """One sensor's verdict: `findings` the causes named; `undistinguished` both readings of a direction-dependent
    error the session cannot attribute (empty unless so); `p` every test's p-value; `lag_inflation` the design's
    power to tell the two apart (sweeps.SweepModel.lag_inflation); `notes` what could not be tested and why."""

    sensor: str
    findings: list[ThermalCause]
    undistinguished: list[ThermalCause]
    p: dict[str, float]
    lag_inflation: float
    notes: list[str]
    evidence: dict = field(default_factory=dict)

    @property
    def named(self) -> set[str]:
        return {f.effect for f in self.findings}

    def as_dict(self) -> dict:
        return {"sensor": self.sensor, "findings": [f.as_dict() for f in self.findings],
                "undistinguished": [f.as_dict() for f in self.undistinguished], "p": self.p,
                "lag_inflation": self.lag_inflation, "distinguishable": self.lag_inflation <= INDISTINCT,
                "notes": self.notes, "evidence": self.evidence}


def thermal_causes(sensor: str, steps: list[SweptStep], alpha: float = ALPHA) -> ThermalCauses:
    """Name and size thermal hysteresis and thermal lag on one sensor's steps (module docstring)."""
    d = sweep_data(sensor, steps)
    model = SweepModel(d)
    notes = []
    both_sweeps = np.any(d.sign > 0) and np.any(d.sign < 0)
    rates_vary = model.tau_bound_s() > 0
    if not both_sweeps:
        notes.append("hysteresis not tested: the steps are all of one sweep direction")
    if not rates_vary:
        notes.append("lag not tested: every step's die temperature rate is zero")
    if not (both_sweeps or rates_vary):
        return ThermalCauses(sensor, [], [], {}, float("inf"), notes, _evidence(steps))
    full = model.fit(both_sweeps, rates_vary)
    if full.dof < 1:
        notes.append(f"not tested: {len(steps)} steps at {model.d.set_points} distinct set points leave no degree of "
                     "freedom beside the curves and the causes; a session up and down through 3 or more set points "
                     "has them")
        return ThermalCauses(sensor, [], [], {}, float("inf"), notes, _evidence(steps))
    m0 = model.fit(False, False)
    mh = model.fit(True, False) if both_sweeps else None
    ml = model.fit(False, True) if rates_vary else None
    inflation = model.lag_inflation() if (both_sweeps and rates_vary) else float("inf")
    p: dict[str, float] = {}
    findings: list[ThermalCause] = []
    undistinguished: list[ThermalCause] = []
    if both_sweeps and rates_vary:
        p["hysteresis_given_lag"] = _lr_p(ml, full)
        p["lag_given_hysteresis"] = _lr_p(mh, full)
        p["either"] = _lr_p(m0, full)
        p["hysteresis_alone"] = _lr_p(m0, mh)
        p["lag_alone"] = _lr_p(m0, ml)
        distinct = inflation <= INDISTINCT
        if p["hysteresis_given_lag"] < alpha / 4:
            findings.append(_hysteresis(sensor, d, full if distinct else mh, p["hysteresis_given_lag"]))
            if not distinct:
                notes.append("hysteresis sized without a lag: no lag explains the sweep offset, but the steps' rates "
                             f"do not tell a lag's share of it (lag deviation x{inflation:.1f} beside the offset)")
        if distinct and p["lag_given_hysteresis"] < alpha / 4:
            findings.append(_lag(sensor, full, p["lag_given_hysteresis"]))
        if not findings and p["either"] < alpha / 2:
            undistinguished = [_hysteresis(sensor, d, mh, p["hysteresis_alone"]), _lag(sensor, ml, p["lag_alone"])]
            why = ("the steps' rates do not tell a lag from a sweep offset" if not distinct else
                   "neither cause is significant beside the other")
            notes.append(f"a direction-dependent error (p = {p['either']:.2g}) that is not distinguishable as "
                         f"hysteresis or lag: {why} (lag deviation x{inflation:.1f} beside the offset)")
    elif both_sweeps:
        p["hysteresis_alone"] = _lr_p(m0, mh)
        if p["hysteresis_alone"] < alpha:
            findings.append(_hysteresis(sensor, d, mh, p["hysteresis_alone"]))
    else:
        p["lag_alone"] = _lr_p(m0, ml)
        if p["lag_alone"] < alpha:
            findings.append(_lag(sensor, ml, p["lag_alone"]))
    evidence = _evidence(steps)
    evidence["reduced_chi2"] = {"curves": m0.chi2 / m0.dof, "full": full.chi2 / full.dof}
    return ThermalCauses(sensor, findings, undistinguished, p, inflation, notes, evidence)


def _lr_p(small: SweepFit, big: SweepFit) -> float:
    """The nested likelihood ratio's p-value (module docstring)."""
    q = small.dof - big.dof
    delta = max(small.chi2 - big.chi2, 0.0)
    reduced = big.chi2 / big.dof if big.dof > 0 else 1.0
    if reduced <= 1.0:
        return float(stats.chi2.sf(delta, q))
    return float(stats.f.sf(delta / q / reduced, q, big.dof))


def _hysteresis(sensor: str, d: SweepData, fit: SweepFit, p: float) -> ThermalCause:
    """The bias half-width in the calibrated frame (H h, the vocabulary's unit) and the scales' in ppm."""
    _, per_unit = REPORT_UNITS[sensor]
    h = fit.h * d.unit
    cov = fit.cov_h * np.outer(d.unit, d.unit)
    bias = d.H_mean @ h[:3] / per_unit
    bias_cov = d.H_mean @ cov[:3, :3] @ d.H_mean.T / per_unit ** 2
    i = int(np.argmax(np.abs(bias)))
    return ThermalCause(THERMAL_HYSTERESIS, sensor, float(abs(bias[i])), float(np.sqrt(bias_cov[i, i])),
                        unit_for(THERMAL_HYSTERESIS, sensor), p,
                        {"bias_half_width": bias.tolist(), "bias_half_width_std": np.sqrt(np.diag(bias_cov)).tolist(),
                         "scale_half_width_ppm": (h[3:] * 1e6).tolist(),
                         "scale_half_width_std_ppm": (np.sqrt(np.diag(cov)[3:]) * 1e6).tolist(),
                         "sign": "up sweep minus down sweep is twice the half-width"})


def _lag(sensor: str, fit: SweepFit, p: float) -> ThermalCause:
    return ThermalCause(THERMAL_LAG, sensor, float(fit.tau_s), float(fit.tau_std_s), unit_for(THERMAL_LAG, sensor),
                        p, {"tau_s": float(fit.tau_s),
                            "sign": "positive: the sensing element lags the thermometer"})


def _evidence(steps: list[SweptStep]) -> dict:
    """What the session says about its temperatures beside the fits: the rates by sweep and, where the air was
    read, the die's mean difference from the air by sweep (a die that trails the air when it is swept)."""
    out: dict = {}
    for sweep in ("up", "down"):
        mine = [s for s in steps if s.sweep == sweep]
        if not mine:
            continue
        rates = np.array([s.rate_c_per_min for s in mine])
        entry = {"steps": len(mine), "rate_c_per_min_mean": float(rates.mean()),
                 "rate_c_per_min_range": [float(rates.min()), float(rates.max())]}
        air = [s.step.temp_c - s.air_c for s in mine if s.air_c is not None and np.isfinite(s.air_c)]
        if air:
            entry["die_minus_air_c_mean"] = float(np.mean(air))
        out[sweep] = entry
    return out


def report_lines(causes: ThermalCauses) -> list[str]:
    """The verdict as text lines for a session's report."""
    s = causes.sensor
    lines = []
    for f in causes.findings:
        lines.append(f"{s}: {f.effect} {_size(f)} (p = {f.p:.2g})")
        if f.effect == THERMAL_HYSTERESIS:
            lines.append(f"{s}:   scale half-width per axis "
                         + ", ".join(f"{v:.0f} ppm" for v in f.params["scale_half_width_ppm"]))
    if causes.undistinguished:
        lines.append(f"{s}: a sweep-dependent error, not distinguishable as " + " or ".join(
            f"{f.effect} {_size(f)}" for f in causes.undistinguished))
    if not causes.p:
        lines.append(f"{s}: thermal hysteresis and lag not tested")
    elif not causes.findings and not causes.undistinguished:
        tested = ", ".join(f"{k} p = {v:.2g}" for k, v in causes.p.items())
        lines.append(f"{s}: no thermal hysteresis or lag beyond the steps' deviations"
                     + (f" ({tested})" if tested else ""))
    lines += [f"{s}: note: {n}" for n in causes.notes if not n.startswith("a direction-dependent")]
    return lines


def _size(f: ThermalCause) -> str:
    return f"{f.magnitude:.4g} +- {f.uncertainty:.2g} {f.unit}"
