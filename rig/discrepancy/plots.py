"""Residual against the finding's covariate, before and after the model is extended (matplotlib Agg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.discrepancy.search import SensorState
from rig.discrepancy.stats import orth, project


def covariate(st: SensorState, cand) -> tuple[np.ndarray, str] | None:
    """The covariate the candidate's residual follows (its `against`), if it names one."""
    return None if cand.against is None else cand.against(st.obs)


def residual_before_after(st: SensorState, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Physical residual (n, 3) of the model without and with accepted effect i (others kept)."""
    acc = st.accepted[i]
    others, st.accepted = st.accepted, [a for j, a in enumerate(st.accepted) if j != i]
    try:
        d = st.design()
        Z = st.weighted(st.columns(acc.cand, acc.scan_value))
    finally:
        st.accepted = others
    Q = orth(d.J)
    rp = d.r - Q @ (Q.T @ d.r)
    P = project(Q, Z)
    e1 = rp - P.U @ (P.U.T @ rp)
    n = st.obs.n
    return (rp * d.scale).reshape(n, 3), (e1 * d.scale).reshape(n, 3)


def write_plots(states: list[SensorState], folder: Path) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for st in states:
        for i, acc in enumerate(st.accepted):
            before, after = residual_before_after(st, i)
            cov = covariate(st, acc.cand)
            signal = before - after
            kinds = [(sel, name) for sel, name in ((~st.obs.is_move, "hold"), (st.obs.is_move, "move"))
                     if sel.any() and np.abs(signal[sel]).max() > 1e-3 * np.abs(signal).max()]
            fig, axes = plt.subplots(len(kinds), 3, figsize=(12, 3.2 * len(kinds)), squeeze=False)
            for row, (sel, name) in enumerate(kinds):
                for a in range(3):
                    if cov is not None and cov[0] is not None:
                        xs = cov[0] if cov[0].ndim == 1 else cov[0][:, a]
                        x, xlabel = xs[sel], cov[1] + ("" if cov[0].ndim == 1 else f" ({'xyz'[a]})")
                    else:
                        x, xlabel = signal[sel, a], f"fitted {acc.cand.effect} term ({'xyz'[a]})"
                    ax = axes[row, a]
                    ax.plot(x, before[sel, a], ".", ms=3, label="linear model")
                    ax.plot(x, after[sel, a], ".", ms=3, label=f"+ {acc.cand.effect}")
                    ax.set_xlabel(xlabel)
                    ax.set_ylabel(f"{st.sensor} {name} residual {'xyz'[a]}")
            axes[0, 0].legend(fontsize=7)
            fig.suptitle(f"{acc.cand.effect} on {st.sensor}")
            fig.tight_layout()
            path = folder / f"{st.sensor}-{acc.cand.effect}.png"
            fig.savefig(path, dpi=90)
            plt.close(fig)
            written.append(str(path))
    return written
