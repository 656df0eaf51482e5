"""The calibration report of one session: `report.md` with PNG figures, and `report.json` with its numbers.

Every number in the Markdown tables is printed with 8 significant digits so the tables can be read
back (by the tests, or by anyone comparing runs); `report.json` carries the same metrics and the
verdict for programs (e.g. the CLI's exit status).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.io.atomic import write_text_atomic
from rig.report.limits import REASONS, LimitCheck, check_limits, validate_limits, verdict
from rig.report.markdown import cell, flattened, number, table
from rig.report.metrics import METRICS, STATIC_SENSORS, SensorMetrics, sensor_metrics
from rig.session_data import SessionData

METADATA_FIRST = ("unit", "unit_serial", "operator", "software", "started", "start_utc", "ended", "end_utc", "status",
                  "status_reason")


@dataclass
class Evaluation:
    """The metrics of every calibrated sensor and the acceptance checks of the limits."""

    metrics: dict[str, SensorMetrics]
    checks: list[LimitCheck]

    @property
    def verdict(self) -> str:
        return verdict(self.checks)

    def failing(self) -> list[str]:
        """One line per check that did not pass: 'gyro residual_rms 0.0031 > 0.002 (FAIL)'."""
        return [f"{c.sensor} {c.metric} {_short(c.value)} > {_short(c.limit)}" if c.result == "FAIL"
                else f"{c.sensor} {c.metric}: not available (limit {_short(c.limit)})"
                for c in self.checks if c.result != "PASS"]


def evaluate(session: SessionData, calibrations: dict[str, TriadCalibration], *, gravity: float,
             field_uT: float | None, truth: dict | None = None, limits: dict | None = None,
             settle_s: float = 0.5) -> Evaluation:
    """Metrics and limit checks of a calibration (what the report shows and the verdict rests on)."""
    validate_limits(limits or {})
    truths = truth_per_sensor(truth)
    metrics = {s: sensor_metrics(session, s, cal, gravity=gravity, field_uT=field_uT, truth=truths.get(s),
                                 settle_s=settle_s) for s, cal in calibrations.items()}
    return Evaluation(metrics, check_limits({s: m.values for s, m in metrics.items()}, limits or {}))


def write_report(out_dir: Path, session: SessionData, calibrations: dict[str, TriadCalibration], *,
                 gravity: float, field_uT: float | None, truth: dict | None = None, limits: dict | None = None,
                 metadata: dict | None = None, settle_s: float = 0.5, evaluation: Evaluation | None = None,
                 plots: bool = True) -> Path:
    """Write `out_dir/report.md` (+ PNGs, `report.json`) and return the path of `report.md`.

    `truth` = {"sensors": {name: {"B": [3], "H": [[3x3]]}}} for simulated sessions; `limits` as in
    `rig.report.limits`; `metadata` defaults to `session.meta`; `settle_s` is dropped at the start of
    every hold before its mean is taken (as the calibration does). `evaluation` (from `evaluate` with the
    same arguments) saves computing the metrics twice. `plots=False`: the tables only (matplotlib is neither
    imported nor run; a session draws its figures on demand, after its result is written).
    """
    out_dir = Path(out_dir)
    truths = truth_per_sensor(truth)
    if evaluation is None:
        evaluation = evaluate(session, calibrations, gravity=gravity, field_uT=field_uT, truth=truth, limits=limits,
                              settle_s=settle_s)
    metrics, checks = evaluation.metrics, evaluation.checks
    out_dir.mkdir(parents=True, exist_ok=True)
    parts = [f"# Calibration report\n\n**Verdict: {verdict(checks)}** ({_passed(checks)})",
             _acceptance_section(checks), _session_section(session, gravity, field_uT)]
    if not plots:
        parts.append("Figures: not drawn for this report (they are drawn on demand: `--plots`).")
    for sensor, cal in calibrations.items():
        parts.append(_sensor_section(out_dir, sensor, cal, metrics[sensor], truths.get(sensor), plots))
    parts.append(_metadata_section(metadata if metadata is not None else session.meta))
    write_text_atomic(out_dir / "report.json", json.dumps(_summary(checks, metrics), indent=2) + "\n")
    return write_text_atomic(out_dir / "report.md", "\n\n".join(parts) + "\n")


def _short(x: float) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{float(x):.4g}"


def truth_per_sensor(truth: dict | None) -> dict[str, dict[str, np.ndarray]]:
    """{sensor: {"B": (3,), "H": (3, 3)}} from the simulator's truth; ValueError naming the sensor if malformed."""
    if truth is None:
        return {}
    sensors = truth.get("sensors") if isinstance(truth, dict) else None
    if not isinstance(sensors, dict):
        raise ValueError("truth must be {'sensors': {name: {'B': [3 values], 'H': [[3x3]]}}}")
    out = {}
    for name, params in sensors.items():
        try:
            B, H = np.asarray(params["B"], dtype=float), np.asarray(params["H"], dtype=float)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"truth['sensors'][{name!r}]: needs numeric 'B' and 'H' ({exc})") from exc
        if B.shape != (3,) or H.shape != (3, 3):
            raise ValueError(f"truth['sensors'][{name!r}]: B has shape {B.shape}, H {H.shape}; need (3,) and (3, 3)")
        out[name] = {"B": B, "H": H}
    return out


def _passed(checks: list[LimitCheck]) -> str:
    if not checks:
        return "no limits given"
    metrics = ", ".join(dict.fromkeys(c.metric for c in checks))
    sensors = ", ".join(dict.fromkeys(c.sensor for c in checks))
    return f"{sum(c.result == 'PASS' for c in checks)} of {len(checks)} checks passed: {metrics} of {sensors}"


def _session_section(session: SessionData, gravity: float, field_uT: float | None) -> str:
    holds = session.hold_rows()
    n_moves = len(np.unique(session.step[session.is_move])) if session.is_move.any() else 0
    span = float(session.t[-1] - session.t[0]) if session.t.size else 0.0
    facts = [["source", session.source], ["sensors", ", ".join(session.sensors)], ["holds", len(holds)],
             ["moves", n_moves], ["rows", int(session.t.size)], ["duration_s", span],
             ["G_mps2", gravity], ["M_uT", "n/a" if field_uT is None else field_uT]]
    return "## Session\n\n" + table(["item", "value"], facts)


def _metadata_section(metadata: dict) -> str:
    """Every metadata key, a nested one as dotted keys, each value whole and readable (markdown.flattened)."""
    keys = [k for k in METADATA_FIRST if k in metadata] + sorted(k for k in metadata if k not in METADATA_FIRST)
    rows = [[k, text] for key in keys for k, text in flattened(metadata[key], key)]
    return "## Metadata\n\n" + (table(["key", "value"], rows) if rows else "none recorded")


def _acceptance_section(checks: list[LimitCheck]) -> str:
    if not checks:
        return "## Acceptance\n\nNo limits were given; nothing was checked."
    rows = [[c.sensor, f"{c.metric}_max", number(c.value), number(c.limit), c.result, REASONS[c.metric]]
            for c in checks]
    return "## Acceptance\n\n" + table(["sensor", "check", "value", "limit", "result", "why it is checked"], rows)


def _sensor_section(out_dir: Path, sensor: str, cal: TriadCalibration, m: SensorMetrics,
                    truth: dict[str, np.ndarray] | None, plots: bool = True) -> str:
    text = [f"## {sensor} [{m.unit}]",
            f"method {cal.method}; iterations {cal.iterations}; converged {cell(cal.converged)}; "
            f"det(H) = {number(np.linalg.det(cal.H))}"]
    text += [f"- warning: {w}" for w in cal.warnings]
    text.append(f"### {sensor} parameters\n\n" + _parameter_table(cal, truth))
    quality = [[name, number(value), metric_unit(name, sensor, m.unit), METRICS[name][0]]
               for name, value in m.values.items()]
    text.append(f"### {sensor} fit quality\n\n" + table(["metric", "value", "unit", "meaning"], quality))
    if m.static is not None and m.static.steps.size:
        text.append(_static_section(out_dir, sensor, cal, m, plots))
    elif sensor in STATIC_SENSORS:
        text.append(f"No hold means of {sensor} checked: "
                    + ("no holds in the session." if m.static is not None else "no reference magnitude given."))
    if m.moves is not None and m.moves.steps.size:
        text.append(_moves_section(out_dir, sensor, m, plots))
    return "\n\n".join(text)


def metric_unit(metric: str, sensor: str, unit: str) -> str:
    """The unit of a metric; the gyro's residual is an angle per move (the UKF matches rotations)."""
    if metric == "residual_rms" and sensor == "gyro":
        return "rad per move"
    return METRICS[metric][1].format(unit=unit)


def _parameter_table(cal: TriadCalibration, truth: dict[str, np.ndarray] | None) -> str:
    rows = []
    for name, values, std in (("B", cal.B, cal.B_std), ("H", cal.H, cal.H_std)):
        values = np.asarray(values, dtype=float)
        for index in np.ndindex(values.shape):
            label = f"{name}[{','.join(map(str, index))}]"
            true = None if truth is None else truth[name][index]
            rows.append([label, number(values[index]), number(None if std is None else np.asarray(std)[index]),
                         number(true), number(None if true is None else values[index] - true)])
    return table(["parameter", "value", "std", "truth", "error"], rows)


def _static_section(out_dir: Path, sensor: str, cal: TriadCalibration, m: SensorMetrics, plots: bool = True) -> str:
    s = m.static
    norms = s.norm_error + s.reference
    rows = [[int(j), number(n), number(e), *map(number, r)] for j, n, e, r in zip(s.steps, norms, s.norm_error, s.residual)]
    v = s.world_vector
    elevation = math.degrees(math.asin(np.clip(v[2] / np.linalg.norm(v), -1, 1))) if np.linalg.norm(v) else float("nan")
    figures = []
    if plots:
        from rig.report import plots as figures_of        # matplotlib only when figures are drawn

        norms_png = figures_of.static_norms_plot(out_dir / f"{sensor}_norms.png", sensor, m.unit, s)
        ellipsoid_png = figures_of.ellipsoid_plot(out_dir / f"{sensor}_ellipsoid.png", sensor, m.unit, s, cal)
        figures = [f"![{sensor} norms and residuals per orientation]({norms_png.name})",
                   f"![{sensor} hold means against the fitted ellipsoid and the sphere]({ellipsoid_png.name})"]
    return "\n\n".join([
        f"### {sensor} per orientation",
        f"Reference magnitude {number(s.reference)} {m.unit}. World vector v = mean_j R_j u_j = "
        f"[{', '.join(number(x, 6) for x in v)}] {m.unit} (|v| = {number(np.linalg.norm(v), 6)}, "
        f"elevation {number(elevation, 6)} deg).",
        table(["step", "norm", "norm_error", "residual_x", "residual_y", "residual_z"], rows), *figures])


def _moves_section(out_dir: Path, sensor: str, m: SensorMetrics, plots: bool = True) -> str:
    mv = m.moves
    rows = [[int(j), number(d), number(r), number(i), number(e)]
            for j, d, r, i, e in zip(mv.steps, mv.duration_s, mv.reference_deg, mv.integrated_deg, mv.error_deg)]
    figures = []
    if plots:
        from rig.report import plots as figures_of

        png = figures_of.moves_plot(out_dir / f"{sensor}_moves.png", mv)
        figures = [f"![{sensor} integrated rotation per move]({png.name})"]
    return "\n\n".join([
        f"### {sensor} per move",
        "Calibrated rates H (y - B) integrated over each move against the reference rotation R_j^T R_j+1.",
        table(["from_step", "duration_s", "reference_deg", "integrated_deg", "error_deg"], rows), *figures])


def _summary(checks: list[LimitCheck], metrics: dict[str, SensorMetrics]) -> dict:
    def clean(x: float) -> float | None:
        return None if x is None or math.isnan(x) else x
    return {"verdict": verdict(checks),
            "checks": [{"sensor": c.sensor, "metric": c.metric, "value": clean(c.value), "limit": c.limit,
                        "result": c.result} for c in checks],
            "sensors": {s: {k: clean(v) for k, v in m.values.items()} for s, m in metrics.items()}}
