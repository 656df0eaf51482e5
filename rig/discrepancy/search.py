"""Forward stepwise search for missing effects (effects-research.md section 2.2, steps 4-7).

Each round tests every remaining candidate of every sensor against that sensor's current model (the
linear model plus the effects accepted so far), Holm-corrects all (candidate, axis) p-values of the
round together, and accepts per sensor the candidate with the lowest delta-BIC among those that pass
all three gates: Holm p < alpha, delta-BIC < -10, held-out gain (Wilcoxon p < 0.05, gain > 2 %, GAIN_MIN).
Two candidates are reported as ambiguous when both pass and the winner is no longer significant
once the other is in the model: the data cannot tell them apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.discrepancy.candidates import Candidate
from rig.discrepancy.linear import TriadFit, flat, solve_step
from rig.discrepancy.observations import Observations
from rig.discrepancy.stats import (Design, Gate, TestResult, heldout_gate, holm, identifiable_fraction, nested_test,
                                   orth, project)

ALPHA = 0.01
DBIC_MAX = -10.0
GAIN_MIN = 0.02
WILCOXON_MAX = 0.05
MAX_EFFECTS = 3


@dataclass
class Accepted:
    cand: Candidate
    scan_value: float | None
    test: TestResult
    gate: Gate
    p_holm: float
    ambiguous_with: list[str] = field(default_factory=list)


@dataclass
class SensorState:
    sensor: str
    obs: Observations
    fit: TriadFit
    candidates: list[Candidate]
    kind_scale: np.ndarray = field(default_factory=lambda: np.ones(2))
    accepted: list[Accepted] = field(default_factory=list)
    base_fit: TriadFit | None = None

    def __post_init__(self):
        self.base_fit = self.base_fit or self.fit

    def columns(self, cand: Candidate, scan_value: float | None, fit: TriadFit | None = None) -> np.ndarray:
        fit = fit or self.fit
        if cand.scan_columns is not None and scan_value is not None:
            return cand.scan_columns(self.obs, fit, scan_value)
        return cand.columns(self.obs, fit)

    def sigma(self) -> np.ndarray:
        return self.fit.sigma(self.obs) * self.kind_scale[self.obs.is_move.astype(int)][:, None]

    def design(self, extra: list[tuple[Candidate, float | None]] = ()) -> Design:
        sig = flat(self.sigma())
        w = 1.0 / sig
        cols = [flat(self.fit.jacobian(self.obs))]
        for a in list(self.accepted_pairs()) + list(extra):
            cols.append(flat(self.columns(*a)))
        J = np.hstack(cols) * w[:, None]
        n = self.obs.n
        kind = np.repeat(self.obs.is_move.astype(int), 3)
        channel = np.tile(np.arange(3), n)
        return Design(r=flat(self.fit.residual(self.obs)) * w, J=J, series=kind * 3 + channel,
                      group=np.repeat(self.obs.group, 3), kind=kind, scale=sig)

    def accepted_pairs(self):
        return [(a.cand, a.scan_value) for a in self.accepted]

    def weighted(self, Z: np.ndarray) -> np.ndarray:
        return flat(Z) / flat(self.sigma())[:, None]


def calibrate_noise_scale(state: SensorState) -> None:
    """Rescale the predicted standard errors of the move windows so their base residual's robust spread
    is 1: windows then weigh against hold means by what they actually scatter (reference noise,
    vibration), while a few windows hit by an effect (ramps) do not move the scale."""
    d = state.design()
    sel = d.kind == 1
    if sel.sum() < 10:
        return
    beta, *_ = np.linalg.lstsq(d.J, d.r, rcond=None)
    e = (d.r - d.J @ beta)[sel]
    mad = 1.4826 * np.median(np.abs(e - np.median(e)))
    if mad > 0:
        state.kind_scale[1] *= mad


def _scan(state: SensorState, cand: Candidate, d: Design) -> tuple[float, int]:
    grid = cand.scan(state.obs)
    Q, _ = np.linalg.qr(d.J)
    rp = d.r - Q @ (Q.T @ d.r)
    best, best_v = -1.0, float(grid[0])
    for v in grid:
        Z = state.weighted(cand.scan_columns(state.obs, state.fit, float(v)))
        Zp = Z - Q @ (Q.T @ Z)
        g, *_ = np.linalg.lstsq(Zp, rp, rcond=None)
        gain = float(rp @ (Zp @ g))
        if gain > best:
            best, best_v = gain, float(v)
    holds = int((~state.obs.is_move).sum())
    return best_v, max(holds - 1, 1)


@dataclass
class Trial:
    state: SensorState
    cand: Candidate
    scan_value: float | None
    test: TestResult
    p_holm: float = 1.0
    gate: Gate | None = None
    identifiable: float = 1.0      # share of the columns' norm the current model cannot absorb

    @property
    def passes_tests(self) -> bool:
        return self.p_holm < ALPHA and self.test.dbic < DBIC_MAX

    @property
    def passes(self) -> bool:
        g = self.gate
        return (self.passes_tests and g is not None and g.p_wilcoxon < WILCOXON_MAX and g.gain > GAIN_MIN
                and self.implausible is None)

    @property
    def implausible(self) -> str | None:
        check = self.cand.implausible
        return None if check is None else check(self.test.coef, self.test.cov)


def try_candidate(state: SensorState, cand: Candidate) -> Trial:
    d = state.design()
    scan_value, bonferroni = (None, 1)
    if cand.scan is not None:
        scan_value, bonferroni = _scan(state, cand, d)
    Z = state.weighted(state.columns(cand, scan_value))
    res = nested_test(d, Z, cand.labels)
    if bonferroni > 1:
        res.p_group = min(1.0, res.p_group * bonferroni)
        res.p_axes = {k: min(1.0, v * bonferroni) for k, v in res.p_axes.items()}
    return Trial(state, cand, scan_value, res, identifiable=identifiable_fraction(d.J, Z))


def run_round(states: list[SensorState]) -> list[Trial]:
    trials = []
    for st in states:
        if len(st.accepted) >= MAX_EFFECTS:
            continue
        done = {a.cand.key for a in st.accepted}
        trials += [try_candidate(st, c) for c in st.candidates if c.key not in done]
    flat_p = [(i, p) for i, t in enumerate(trials) for p in t.test.p_axes.values()]
    adj = holm([p for _, p in flat_p])
    for (i, _), a in zip(flat_p, adj):
        trials[i].p_holm = min(trials[i].p_holm, float(a))
    for t in trials:
        if t.passes_tests:
            t.gate = heldout_gate(t.state.design(), t.state.weighted(t.state.columns(t.cand, t.scan_value)))
    return trials


def _ambiguous(winner: Trial, others: list[Trial]) -> list[str]:
    out = []
    for o in others:
        st = winner.state
        d = st.design(extra=[(o.cand, o.scan_value)])
        Z = st.weighted(st.columns(winner.cand, winner.scan_value))
        if nested_test(d, Z, winner.cand.labels).p_group > ALPHA:
            out.append(o.cand.effect)
    return out


def extended_fit(st: SensorState, fit: TriadFit | None = None, iterations: int = 3) -> TriadFit:
    """Gauss-Newton refit of base + every accepted effect, columns rebuilt at each iterate and reduced
    to the directions the base cannot absorb (so (B, H, v) do not wander along absorbed ones)."""
    fit = fit or st.fit
    if not st.accepted:
        return fit
    for _ in range(iterations):
        sig = fit.sigma(st.obs) * st.kind_scale[st.obs.is_move.astype(int)][:, None]
        w = (1.0 / sig).reshape(-1)
        J = flat(fit.jacobian(st.obs)) * w[:, None]
        Zs = []
        for a in st.accepted:
            Z = flat(st.columns(a.cand, a.scan_value, fit))
            P = project(orth(J), Z * w[:, None])
            Zs.append(Z @ (P.V / P.norms[:, None]))
        n = st.obs.n
        Zr = np.concatenate(Zs, axis=1).reshape(n, 3, -1)
        delta, _ = solve_step(fit, st.obs, Zr, w=w)
        fit = fit.updated(delta)
    return fit


def stepwise(states: list[SensorState]) -> list[Trial]:
    """Accept effects round by round; returns the first round's trials (every candidate vs the base)."""
    first: list[Trial] | None = None
    for _ in range(MAX_EFFECTS):
        trials = run_round(states)
        if first is None:
            first = trials
        accepted_any = False
        for st in states:
            passing = [t for t in trials if t.state is st and t.passes]
            if not passing:
                continue
            win = min(passing, key=lambda t: t.test.dbic)
            amb = _ambiguous(win, [t for t in passing if t is not win])
            st.accepted.append(Accepted(win.cand, win.scan_value, win.test, win.gate, win.p_holm, amb))
            st.fit = extended_fit(st)
            accepted_any = True
        if not accepted_any:
            break
    return first or []
