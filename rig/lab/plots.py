"""The history plot of a unit for the command line (matplotlib): B and the diagonal of H of each sensor over
time, with their standard deviations as error bars and drifted calibrations marked."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.lab.identity import parse_utc


def history_figure(data: dict, path: str | Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    entries = data["calibrations"]
    sensors = sorted({s for e in entries for s in e["sensors"]})
    fig, axes = plt.subplots(len(sensors), 2, figsize=(11, 2.8 * len(sensors)), squeeze=False)
    times = [parse_utc(e["started_utc"]) for e in entries]
    for row, sensor in enumerate(sensors):
        for col, (name, label) in enumerate((("B", "B (counts)"), ("H", "diag H (unit/count)"))):
            ax = axes[row][col]
            for axis in range(3):
                xs, ys, es = [], [], []
                for when, e in zip(times, entries):
                    cal = e["sensors"].get(sensor)
                    if not cal or cal.get(name) is None:
                        continue
                    value = np.asarray(cal[name], dtype=float)
                    std = cal.get(f"{name}_std")
                    std = np.asarray(std, dtype=float) if std is not None else np.zeros_like(value)
                    pick = (axis,) if name == "B" else (axis, axis)
                    xs.append(when)
                    ys.append(value[pick])
                    es.append(std[pick])
                ax.errorbar(xs, ys, yerr=es, marker="o", capsize=3, label="xyz"[axis])
            for when, e in zip(times, entries):
                if e.get("drift", {}).get(sensor, {}).get("flagged"):
                    ax.axvline(when, color="red", alpha=0.3)
            ax.set_title(f"{sensor} {label}", fontsize=9)
            ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
            ax.legend(fontsize=7)
    fig.suptitle(f"unit {data['unit']}: {len(entries)} calibrations (red: drift > {data['z_flag']:g} sigma)")
    fig.autofmt_xdate()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
