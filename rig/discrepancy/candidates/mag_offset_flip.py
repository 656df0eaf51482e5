"""The discrepancy analysis's candidate test of `mag_offset_flip`: bridge magnetisation flipped by a strong field
(set/reset)."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, against_time, candidate_test, per_axis


@candidate_test("mag_offset_flip")
def mag_offset_flip(sensor: str) -> Candidate:
    """Offset step at an unknown instant: the columns are the fraction of each hold after t_flip; the
    instant is searched (hold starts and every 0.1 s inside holds) and the p-value Bonferroni-corrected."""
    def grid(o):
        holds = ~o.is_move
        starts, ends = o.t_start[holds], o.t_end[holds]
        inside = [np.arange(s, e, 0.1)[1:] for s, e in zip(starts[1:], ends[1:])]
        return np.unique(np.concatenate([starts[1:], *inside]))

    def at(o, f, t_flip):
        span = np.maximum(o.t_end - o.t_start, 1e-9)
        frac = np.clip((o.t_end - t_flip) / span, 0.0, 1.0)
        return per_axis(frac)
    return Candidate(lambda o, f: np.zeros((o.n, 3, 3)), AXES, lambda c: float(np.linalg.norm(c)),
                     lambda c: {"step_uT": c.tolist()}, scan=grid, scan_columns=at,
                     note="offset steps at t_flip (change point in time)", against=against_time)
