"""Figures of the attitude validation (Agg canvas, no pyplot state)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from rig.attitude.compare import AXES, rpy_deg
from rig.rotations import matrix_from_quat

DPI = 110


def _figure(rows: int, size: tuple[float, float]):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]


def attitude_plot(path: Path, session, result) -> Path:
    """Reference and estimated (ours, aligned) roll, pitch, yaw over the record."""
    ours = result.ours().comparison
    ref = rpy_deg(matrix_from_quat(session.q_ref))
    fig, axs = _figure(3, (9, 7))
    for i, (ax, name) in enumerate(zip(axs, AXES)):
        ax.plot(session.t, ref[:, i], color="k", lw=1.2, label="reference (encoders)")
        ax.plot(session.t, ours.est_rpy_deg[:, i], color="tab:red", lw=0.8, ls="--", label=result.ours().label)
        ax.set_ylabel(f"{name} (deg)")
        ax.grid(alpha=0.3)
    axs[0].legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("t (s)")
    fig.suptitle("Attitude on the validation trajectory")
    fig.savefig(path, dpi=DPI)
    return path


def error_plot(path: Path, session, result) -> Path:
    """Error rotation roll, pitch, yaw of every estimator; the first hold (alignment) is shaded."""
    fig, axs = _figure(3, (9, 8))
    still = result.session_rows.still
    for i, (ax, name) in enumerate(zip(axs, AXES)):
        for row in result.rows:
            ax.plot(session.t, row.comparison.err_deg[:, i], lw=0.8, label=row.label)
        ax.axvspan(session.t[still[0]], session.t[still[-1]], color="0.9", zorder=0)
        ax.set_ylabel(f"{name} error (deg)")
        lim = max(0.5, 1.5 * max(np.nanpercentile(np.abs(r.comparison.err_deg[:, i]), 99) for r in result.rows[:2]))
        ax.set_ylim(-lim, lim)
        ax.grid(alpha=0.3)
    axs[0].legend(loc="upper right", fontsize=7, ncol=2)
    axs[-1].set_xlabel("t (s)")
    fig.suptitle("Error rotation R_ref^T R_est (shaded: first hold, used to align the frames)")
    fig.savefig(path, dpi=DPI)
    return path
