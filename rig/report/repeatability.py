"""Repeatability of a calibration over several runs of the same unit: spread of every element of B and H.

The figure shows, per element, each run's value and the mean +- one sample standard deviation (the
presentation of Zhang 2015, Fig. 7); the table gives the same numbers, and against a simulator's truth
the error of the mean.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.io.atomic import write_text_atomic
from rig.report import plots
from rig.report.calibration_report import truth_per_sensor
from rig.report.markdown import number, table
from rig.report.metrics import sensor_unit

ELEMENTS = [f"B[{i}]" for i in range(3)] + [f"H[{i},{j}]" for i in range(3) for j in range(3)]


def parameter_vector(cal: TriadCalibration) -> np.ndarray:
    """(12,) B then H row-major, the order of `ELEMENTS`."""
    return np.concatenate([np.asarray(cal.B, dtype=float).ravel(), np.asarray(cal.H, dtype=float).ravel()])


def write_repeatability_report(out_dir: Path, runs: list[dict[str, TriadCalibration]], *,
                               truth: dict | None = None) -> Path:
    """Write `out_dir/repeatability.md` (+ one PNG per sensor, `repeatability.json`); return the .md path."""
    if not runs:
        raise ValueError("write_repeatability_report: no runs given")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    truths = truth_per_sensor(truth)
    sensors = list(dict.fromkeys(s for run in runs for s in run))
    parts = [f"# Repeatability report\n\n{len(runs)} runs; spread = sample standard deviation (ddof = 1) "
             "of each element over the runs that calibrated the sensor."]
    summary = {}
    for sensor in sensors:
        values = np.array([parameter_vector(run[sensor]) for run in runs if sensor in run])
        true = parameter_vector_of(truths[sensor]) if sensor in truths else None
        section, summary[sensor] = _sensor_section(out_dir, sensor, values, true)
        parts.append(section)
    write_text_atomic(out_dir / "repeatability.json", json.dumps({"runs": len(runs), "sensors": summary}, indent=2) + "\n")
    return write_text_atomic(out_dir / "repeatability.md", "\n\n".join(parts) + "\n")


def parameter_vector_of(params: dict[str, np.ndarray]) -> np.ndarray:
    return np.concatenate([params["B"].ravel(), params["H"].ravel()])


def _sensor_section(out_dir: Path, sensor: str, values: np.ndarray, true: np.ndarray | None) -> tuple[str, dict]:
    n = len(values)
    mean = values.mean(axis=0)
    std = values.std(axis=0, ddof=1) if n > 1 else np.full(values.shape[1], np.nan)
    rows = []
    for e, label in enumerate(ELEMENTS):
        rel = 100.0 * std[e] / abs(mean[e]) if mean[e] != 0 else np.nan
        rows.append([label, n, number(mean[e]), number(std[e]), number(rel),
                     number(None if true is None else true[e]), number(None if true is None else mean[e] - true[e])])
    unit = sensor_unit(sensor)
    png = plots.repeatability_plot(out_dir / f"repeatability_{sensor}.png", sensor, unit, ELEMENTS, values, true)
    text = "\n\n".join([
        f"## {sensor} [B in counts, H in {unit}/count]",
        table(["element", "runs", "mean", "std", "std_pct_of_mean", "truth", "mean_error"], rows),
        f"![{sensor} repeatability of B and H]({png.name})"])
    summary = {"runs": n, "elements": ELEMENTS, "mean": mean.tolist(),
               "std": [None if np.isnan(s) else float(s) for s in std]}
    return text, summary
