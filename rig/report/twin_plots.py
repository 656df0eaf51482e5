"""Pictures of a recording against its twin (`rig-twin/1`): where each statistic falls in its replicas' band, before
and after the model is extended, and the Allan deviation and pose spreads a person reads first."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

BEFORE, AFTER, REAL = "#c8c8c8", "#7fb3e0", "#c0392b"


def write_twin_plots(report: dict, folder: Path) -> list[Path]:
    """The figures of one twin report, written as PNG files in `folder`; their paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stats = report["statistics"]
    files = [_band_positions(stats, folder / "twin_statistics.png")]
    for sensor in ("accel", "gyro", "mag"):
        if any(n.startswith(f"{sensor}.adev.") for n in stats):
            files.append(_allan(stats, sensor, folder / f"twin_allan_{sensor}.png"))
        if any(n.startswith(f"{sensor}.spread.") for n in stats):
            files.append(_spreads(stats, sensor, folder / f"twin_spread_{sensor}.png"))
    return files


def _position(value: float, band: list) -> float:
    """Where a value sits in a band: -1 at its 1 % end, +1 at its 99 %, 0 at the median; beyond: outside."""
    lo, hi, mid = band
    if value >= mid:
        return (value - mid) / (hi - mid) if hi > mid else (0.0 if value == mid else 9.0)
    return (value - mid) / (mid - lo) if mid > lo else -9.0


def _band_positions(stats: dict, path: Path) -> Path:
    families = sorted({s["family"] for s in stats.values()})
    fig = Figure(figsize=(11, 0.32 * len(families) + 1.8))
    ax = fig.add_subplot(1, 1, 1)
    for row, fam in enumerate(families):
        names = [n for n, s in stats.items() if s["family"] == fam]
        for key, colour, dy in (("before", BEFORE, 0.15), ("after", AFTER, -0.15)):
            x = np.clip([_position(stats[n]["real"], stats[n][key]) for n in names], -4, 4)
            ax.scatter(x, np.full(len(x), row + dy), s=10, color=colour, edgecolor="none")
    ax.axvspan(-1, 1, color="#eaf4ea", zorder=0)
    ax.set_yticks(range(len(families)), families, fontsize=8)
    ax.set_xlim(-4.2, 4.2)
    ax.set_xlabel("real value within the replicas' band (-1: 1 %, 0: median, +1: 99 %; clipped at 4)")
    ax.set_title("Every statistic of the recording against its twin: grey before, blue after the extension")
    fig.tight_layout()
    FigureCanvasAgg(fig).print_png(str(path))
    return path


def _allan(stats: dict, sensor: str, path: Path) -> Path:
    fig = Figure(figsize=(11, 3.4))
    for k, axis in enumerate("xyz"):
        ax = fig.add_subplot(1, 3, k + 1)
        names = sorted((n for n in stats if n.startswith(f"{sensor}.adev.{axis}@")),
                       key=lambda n: float(n.split("@")[1].rstrip("s")))
        if not names:
            continue
        tau = np.array([float(n.split("@")[1].rstrip("s")) for n in names])
        for key, colour, label in (("before", BEFORE, "twin"), ("after", AFTER, "twin, extended")):
            lo = [stats[n][key][0] for n in names]
            hi = [stats[n][key][1] for n in names]
            ax.fill_between(tau, lo, hi, color=colour, alpha=0.7, label=label)
        ax.plot(tau, [stats[n]["real"] for n in names], "o-", color=REAL, ms=3, label="recording")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("tau, s")
        ax.set_title(f"{sensor} {axis}: Allan deviation", fontsize=9)
        if k == 0:
            ax.legend(fontsize=7)
    fig.tight_layout()
    FigureCanvasAgg(fig).print_png(str(path))
    return path


def _spreads(stats: dict, sensor: str, path: Path) -> Path:
    fig = Figure(figsize=(11, 3.4))
    for k, axis in enumerate("xyz"):
        ax = fig.add_subplot(1, 3, k + 1)
        names = [n for n in stats if n.startswith(f"{sensor}.spread.{axis}[")]
        x = np.arange(len(names))
        for key, colour, dx in (("before", BEFORE, -0.15), ("after", AFTER, 0.15)):
            lo = np.array([stats[n][key][0] for n in names])
            hi = np.array([stats[n][key][1] for n in names])
            ax.bar(x + dx, hi - lo, bottom=lo, width=0.3, color=colour)
        ax.plot(x, [stats[n]["real"] for n in names], "o", color=REAL, ms=4)
        if len(names) <= 12:
            ax.set_xticks(x, [n.split("[")[1].rstrip("]") for n in names], rotation=60, fontsize=7)
        else:
            ax.set_xlabel("pose")
        ax.set_title(f"{sensor} {axis}: spread within each pose (raw units)", fontsize=9)
    fig.tight_layout()
    FigureCanvasAgg(fig).print_png(str(path))
    return path
