"""Attitude validation on the turntable (the paper's Table III): after a calibration, run the dynamic
trajectory on the same unit, filter the calibrated data and compare with the encoder reference.

Rows of the table, all on the same trajectory record:
* UKF with our calibration (`rig.pipeline.calibrate_session`, joint or two-step for accel/mag),
* UKF with the SQP calibration (SLSQP accel/mag, trust-region gyro: the paper's comparisons),
* UKF with the sensor-frame-only ellipsoid for accel/mag (gyro: ours, so the row isolates what a
  symmetric H loses: the mounting rotation),
* UKF with nominal datasheet scales (the drivers' `settings()["scale"]`, zero bias),
* Madgwick, Mahony and EKF from `ahrs` on our calibrated data, as peers of the filter (the EKF three
  times: given our noise model, the same fed the UKF's zero-rate steps, and with the package's defaults).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from procedures.orchestrator import RigFactory, RigSpec, SessionOrchestrator
from procedures.session import motion_settings
from procedures.trajectory import run_trajectory
from rig.attitude.compare import AXES
from rig.attitude.evaluate import Row, SessionRows, peer_rows, session_rows, ukf_row
from rig.attitude.peers import PEERS
from rig.attitude.plots import attitude_plot, error_plot
from rig.attitude.ukf import AttitudeEstimate, UKFSettings
from rig.calibration.turntable.gyro import gyro_bias
from rig.calibration.turntable.gyro_baselines import calibrate_gyro_trust_region
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.turntable.vector_baselines import calibrate_sensor_frame_only, calibrate_sqp
from rig.errors import CalibrationError, StopSignal
from rig.io.calibration_json import read_calibration, triads_from_calibration
from rig.io.session_writer import write_session
from rig.session_data import SessionData
from rig.store import SessionStore

OURS = "ours"


@dataclass
class ValidationResult:
    rows: list[Row]
    session_rows: SessionRows
    estimates: dict[str, AttitudeEstimate] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def row(self, label_start: str) -> Row:
        return next(r for r in self.rows if r.label.startswith(label_start))

    def ours(self) -> Row:
        return next(r for r in self.rows if r.filter == "ukf" and r.calibration.startswith(OURS))

    def to_dict(self) -> dict:
        ours = self.ours()
        return {"rms_deg": ours.comparison.rms(), "estimator": ours.label,
                "alignment": ours.comparison.alignment, "filter": ours.filter_summary,
                "evaluated_rows": int(len(self.session_rows.evaluate)),
                "table": [r.to_dict() for r in self.rows], "notes": self.notes}


def nominal_calibration(chips: dict) -> dict[str, TriadCalibration]:
    """Datasheet scales (`settings()["scale"]`, unit per count) and zero bias: no calibration at all."""
    out = {}
    for name in ("accel", "gyro", "mag"):
        s = (chips or {}).get(name, {})
        if isinstance(s, dict) and s.get("scale"):
            out[name] = TriadCalibration(B=np.zeros(3), H=float(s["scale"]) * np.eye(3), method="nominal")
    return out


def baseline_calibrations(cal_session: SessionData, ours: dict[str, TriadCalibration],
                          settle_s: float = 0.5) -> dict[str, dict[str, TriadCalibration]]:
    """SQP and sensor-frame-only calibrations from the same calibration session's holds and moves."""
    norms = {"accel": cal_session.gravity, "mag": cal_session.field_uT}
    sqp, frame_only = {}, {}
    for name in ("accel", "mag"):
        if name not in cal_session.raw:
            continue
        h = cal_session.holds(name, settle_s)
        sqp[name] = calibrate_sqp(h.mean, h.R, norms[name])
        frame_only[name] = calibrate_sensor_frame_only(h.mean, norms[name])
    hg = cal_session.holds("gyro", settle_s)
    sqp["gyro"] = calibrate_gyro_trust_region(cal_session.moves("gyro"), gyro_bias(hg.mean, hg.count))
    frame_only["gyro"] = ours["gyro"]
    return {"SQP": sqp, "sensor-frame only": frame_only}


def validate_session(session: SessionData, calibrations: dict[str, dict[str, TriadCalibration]], *,
                     peers: tuple[str, ...] = PEERS, settings: UKFSettings | None = None) -> ValidationResult:
    """Table III rows for `session`: the UKF with each calibration, the peers with the first one.

    The first entry of `calibrations` is the calibration under test (labelled 'ours ...').
    """
    if not calibrations:
        raise ValueError("validate_session needs at least one calibration")
    rows = session_rows(session)
    result = ValidationResult([], rows)
    first = next(iter(calibrations))
    for label, sensors in calibrations.items():
        try:
            row, est, aligned = ukf_row(session, sensors, label, rows, settings)
        except CalibrationError as e:
            result.notes.append(f"{label}: not evaluated ({e})")
            continue
        result.rows.append(row)
        result.estimates[label] = est
        if label == first and peers:
            result.rows += peer_rows(session, aligned, label, rows, est, peers)
    if first not in result.estimates:
        raise CalibrationError(f"{session.source}: the calibration under test cannot be evaluated: {result.notes[0]}")
    return result


def table3_markdown(result: ValidationResult) -> str:
    """Table III layout: per axis RMS, mean, SD of the error (deg) and the estimate/reference correlation."""
    head = "| estimator | " + " | ".join(f"{a} RMS | {a} mean | {a} SD | {a} corr" for a in AXES) + " |"
    sep = "|---|" + "---:|" * (4 * len(AXES))
    lines = [head, sep]
    for r in result.rows:
        s = r.comparison.stats
        cells = [f"{s[a].rms:.3f} | {s[a].mean:+.3f} | {s[a].sd:.3f} | {s[a].corr:.5f}" for a in AXES]
        lines.append(f"| {r.label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_outputs(out_dir: Path, result: ValidationResult, session: SessionData, *, title: str,
                  extra: dict | None = None, plots: bool = True) -> dict:
    """validation.json, report.md and (optionally) the attitude and error plots in `out_dir`."""
    out_dir.mkdir(parents=True, exist_ok=True)
    doc = {**result.to_dict(), **(extra or {})}
    files = []
    if plots:
        files = [attitude_plot(out_dir / "attitude.png", session, result),
                 error_plot(out_dir / "attitude_error.png", session, result)]
        doc["plots"] = [p.name for p in files]
    (out_dir / "validation.json").write_text(json.dumps(doc, indent=2) + "\n")
    ours = result.ours()
    a = ours.comparison.alignment
    f = ours.filter_summary
    md = [f"# {title}", "", f"Evaluated rows: {len(result.session_rows.evaluate)} (every row after the first hold; "
          "the frames are aligned on the first hold).", "", "## Table III", "", table3_markdown(result), "",
          "Errors are the roll, pitch, yaw of the error rotation R_ref^T R_est (deg); corr is the correlation of "
          "the estimated and reference angle.", "", "## Frame alignment (ours)", "",
          f"navigation frame vs world frame: {a['angle_deg']:.3f} deg about {np.round(a['axis'], 4).tolist()} "
          f"(roll/pitch/yaw {', '.join(f'{v:.3f}' for v in a['rpy_deg'].values())} deg)", "",
          "## Filter (ours)", "",
          f"- noise: gyro {f['noise']['gyro_rad_s']:.3g} rad/s, accel {f['noise']['accel_mps2']:.3g} m/s^2, "
          f"mag {f['noise']['mag_uT']:.3g} uT (from the first hold, floored)",
          f"- reference dip {f['dip_deg']:.2f} deg, |m| {f['field_uT']:.2f} uT",
          "- latency behind the stamps, estimated against the reference and removed: "
          + ", ".join(f"{k} {1e3 * v:.2f} ms" for k, v in f["latency_s"].items()),
          f"- accel updates {f['accel_updates']} (rejected {f['accel_rejected']}); magnetometer samples "
          f"{f['mag_samples']}, used {f['mag_updates']}, rejected for |m| {f['mag_rejected_norm']}, "
          f"for dip {f['mag_rejected_dip']}",
          f"- zero-rate steps (the gyro showed only noise; attitude kept): {f.get('still_steps', 0)}",
          "- accelerometer lever arm removed before every filter: "
          + (f"r = {np.round(f['lever_arm_compensated_m'], 5).tolist()} m" if f.get("lever_arm_compensated_m")
             else "none (not significant in the calibration, or not estimated)")]
    if result.notes:
        md += ["", "## Notes", ""] + [f"- {n}" for n in result.notes]
    if files:
        md += ["", "## Plots", ""] + [f"![{p.stem}]({p.name})" for p in files]
    (out_dir / "report.md").write_text("\n".join(md) + "\n")
    return doc


def run_trajectory_on(rig, config) -> SessionData:
    """The dynamic trajectory on a built rig; the session carries G, M and the chip settings."""
    rig.board.start()
    session = run_trajectory(rig.table, rig.board, rig.clock, config.geometry, motion_settings(config))
    session.gravity, session.field_uT = float(config.gravity_mps2), float(config.field_uT)
    session.meta["chips"] = rig.board.settings()
    return session


def validate_on_rig(out_dir: Path, config, *, sim: bool = True, seed: int = 0, calibration: Path | None = None,
                    method: str = "joint", peers: tuple[str, ...] = PEERS, plots: bool = True,
                    settings: UKFSettings | None = None, echo=print,
                    build_rig: RigFactory) -> tuple[ValidationResult, dict]:
    """Calibrate the unit (or take `calibration`), record the trajectory on it, write the Table III report.

    Simulated: the calibration session and the trajectory run on the same simulated unit (the seed
    fixes its sensor errors; the trajectory uses another noise trial). `build_rig(config, RigSpec)` makes
    the rig (the application's `rig.assembly.build_rig`).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if calibration is None:
        calibration_dir = out_dir / "calibration"
        outcome = SessionOrchestrator(calibration_dir, build_rig, method=method).start(config, RigSpec(sim, seed))
        if outcome.status == "aborted":
            raise StopSignal(outcome.signum)
        if outcome.status not in ("complete", "rejected"):
            raise CalibrationError(f"the calibration session in {calibration_dir} ended {outcome.status}: "
                                   f"{outcome.reason}")
        calibration = calibration_dir / "calibration.json"
    doc = read_calibration(calibration)
    ours = triads_from_calibration(doc)
    calibrations = {f"{OURS} ({_methods(ours)})": ours}
    cal_session = _calibration_session(doc, Path(calibration))
    if cal_session is not None:
        calibrations.update(baseline_calibrations(cal_session, ours))
    with build_rig(config, RigSpec(sim, seed, None, trial=1)) as rig:
        session = run_trajectory_on(rig, config)
    calibrations["nominal datasheet"] = nominal_calibration(session.meta["chips"])
    write_session(session, out_dir / "trajectory")
    result = validate_session(session, calibrations, peers=peers, settings=settings)
    if cal_session is None:
        result.notes.append(f"{calibration}: its calibration session was not found; SQP and sensor-frame rows skipped")
    extra = {"calibration": str(calibration), "simulated": sim, "seed": seed if sim else None,
             "trajectory": str(out_dir / "trajectory")}
    where = "the simulated turntable" if sim else "the turntable"
    doc_out = write_outputs(out_dir, result, session, title=f"Attitude validation on {where}",
                            extra=extra, plots=plots)
    echo(table3_markdown(result))
    echo(f"wrote {out_dir / 'report.md'} and {out_dir / 'validation.json'}")
    return result, doc_out


def _methods(sensors: dict[str, TriadCalibration]) -> str:
    return ", ".join(sorted({c.method for c in sensors.values()}))


def _calibration_session(doc: dict, calibration: Path) -> SessionData | None:
    """The session a calibration file came from, when it is still beside it (for the baseline rows)."""
    for folder in (doc.get("session"), calibration.parent):
        if folder and (Path(folder) / "session.sqlite").exists():
            return SessionStore.open(Path(folder)).to_session_data()
    return None
