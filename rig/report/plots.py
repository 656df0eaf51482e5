"""PNG figures of the reports, drawn on the Agg canvas (no pyplot state, no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from rig.calibration.numerics.result import TriadCalibration
from rig.report.metrics import MoveCheck, StaticCheck

PLANES = ((0, 1), (0, 2), (1, 2))
AXES = "xyz"
DPI = 110


def _figure(rows: int, cols: int, size: tuple[float, float]) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, np.atleast_1d(fig.subplots(rows, cols, squeeze=False))


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=DPI)
    return path


def static_norms_plot(path: Path, sensor: str, unit: str, check: StaticCheck) -> Path:
    """|H(y-B)| per orientation against the reference, and the residuals per orientation."""
    fig, ax = _figure(2, 1, (7.5, 6.0))
    top, bottom = ax[0, 0], ax[1, 0]
    x = np.arange(check.steps.size)
    norms = check.norm_error + check.reference
    top.plot(x, norms, "o", label="|H (y - B)| of hold mean")
    top.axhline(check.reference, color="k", lw=1, label=f"reference {check.reference:g} {unit}")
    top.set_ylabel(f"norm [{unit}]")
    top.set_title(f"{sensor}: calibrated hold means against the sphere")
    top.legend(loc="best")
    width = 0.2
    bottom.bar(x - 1.5 * width, check.norm_error, width, label="|u| - reference")
    for k in range(3):
        bottom.bar(x + (k - 0.5) * width, check.residual[:, k], width, label=f"(u - R^T v)_{AXES[k]}")
    bottom.axhline(0.0, color="k", lw=0.8)
    bottom.set_ylabel(f"residual [{unit}]")
    bottom.set_title("residuals per orientation")
    for a in (top, bottom):
        a.set_xticks(x, [str(s) for s in check.steps])
        a.set_xlabel("orientation (step)")
    bottom.legend(loc="best", fontsize="small", ncols=2)
    return _save(fig, path)


def ellipsoid_plot(path: Path, sensor: str, unit: str, check: StaticCheck, cal: TriadCalibration) -> Path:
    """Raw hold means against the fitted ellipsoid |H(y-B)| = r (top) and calibrated against the sphere."""
    fig, ax = _figure(2, 3, (11.0, 7.0))
    A = check.reference * np.linalg.inv(cal.H)          # y = B + A s, |s| = 1
    circle = np.stack([np.cos(np.linspace(0, 2 * np.pi, 200)), np.sin(np.linspace(0, 2 * np.pi, 200))])
    for col, (i, j) in enumerate(PLANES):
        P = np.eye(3)[[i, j]]
        L = np.linalg.cholesky(P @ A @ A.T @ P.T)
        outline = (P @ cal.B)[:, None] + L @ circle
        raw = ax[0, col]
        raw.plot(outline[0], outline[1], "k-", lw=1, label="fitted ellipsoid (outline)")
        raw.plot(check.raw_means[:, i], check.raw_means[:, j], "o", ms=4, label="raw hold means")
        raw.set_xlabel(f"y_{AXES[i]} [counts]")
        raw.set_ylabel(f"y_{AXES[j]} [counts]")
        cal_ax = ax[1, col]
        cal_ax.plot(check.reference * circle[0], check.reference * circle[1], "k-", lw=1, label="sphere (outline)")
        cal_ax.plot(check.calibrated[:, i], check.calibrated[:, j], "o", ms=4, label="H (y - B)")
        cal_ax.set_xlabel(f"u_{AXES[i]} [{unit}]")
        cal_ax.set_ylabel(f"u_{AXES[j]} [{unit}]")
        for a in (raw, cal_ax):
            a.set_aspect("equal", adjustable="datalim")
    ax[0, 0].legend(loc="best", fontsize="small")
    ax[1, 0].legend(loc="best", fontsize="small")
    fig.suptitle(f"{sensor}: hold means, projections on the coordinate planes")
    return _save(fig, path)


def moves_plot(path: Path, moves: MoveCheck) -> Path:
    """Per move: the reference and integrated rotation angles, and the angle between them."""
    fig, ax = _figure(2, 1, (7.5, 6.0))
    top, bottom = ax[0, 0], ax[1, 0]
    x = np.arange(moves.steps.size)
    top.bar(x - 0.2, moves.reference_deg, 0.4, label="reference R_j^T R_j+1")
    top.bar(x + 0.2, moves.integrated_deg, 0.4, label="integrated gyro")
    top.set_ylabel("rotation angle [deg]")
    top.set_title("gyro: rotation over each move")
    top.legend(loc="best")
    bottom.bar(x, moves.error_deg, 0.6, color="tab:red")
    bottom.set_ylabel("angle(R_ref^T R_int) [deg]")
    bottom.set_title("integration error per move")
    for a in (top, bottom):
        a.set_xticks(x, [f"{s}->{s + 1}" for s in moves.steps], rotation=45)
        a.set_xlabel("move (from step)")
    return _save(fig, path)


def repeatability_plot(path: Path, sensor: str, unit: str, labels: list[str], values: np.ndarray,
                       truth: np.ndarray | None) -> Path:
    """Every element of B (top row) and H (3 x 3 below) over the runs: each run, mean +- one std, truth.

    One panel per element, laid out like B and H, because the elements differ by orders of magnitude.
    """
    fig, ax = _figure(4, 3, (10.0, 10.0))
    mean, std = values.mean(axis=0), values.std(axis=0, ddof=1) if len(values) > 1 else np.zeros(values.shape[1])
    runs = np.arange(len(values))
    for e, label in enumerate(labels):
        a = ax[e // 3, e % 3]
        a.plot(runs, values[:, e], ".", color="0.6", label="runs")
        a.errorbar([len(values) + 0.5], [mean[e]], yerr=[std[e]], fmt="o", capsize=4, label="mean +- std")
        if truth is not None:
            a.axhline(truth[e], color="k", lw=0.8, ls="--", label="truth")
        a.set_title(f"{label} [{'counts' if e < 3 else unit + '/count'}]", fontsize="small")
        a.tick_params(labelsize="x-small")
    ax[0, 0].legend(loc="best", fontsize="x-small")
    for a in ax[-1]:
        a.set_xlabel("run")
    fig.suptitle(f"{sensor}: repeatability over {len(values)} runs")
    return _save(fig, path)
