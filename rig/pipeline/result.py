"""What calibrating a session gives: per-sensor calibrations and what the user must know about how they were made."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.pipeline.screening import vec
from rig.units import SENSOR_UNITS


@dataclass
class SessionCalibration:
    """Per-sensor calibrations of one session plus what the user must know about how they were made."""

    sensors: dict[str, TriadCalibration]
    warnings: list[str] = field(default_factory=list)
    summary: list[str] = field(default_factory=list)
    excluded_steps: dict[int, str] = field(default_factory=dict)
    holds_used: dict[str, int] = field(default_factory=dict)
    raw_units: dict[str, str] = field(default_factory=dict)     # a recording's raw columns may be in SI units
    refused: dict[str, str] = field(default_factory=dict)       # sensor -> why it could not be calibrated


def summary_lines(result: SessionCalibration) -> list[str]:
    """Per sensor: method, holds, residual, iterations, B and H with their standard deviations."""
    lines = []
    for name, cal in result.sensors.items():
        unit = cal.extra.get("unit", SENSOR_UNITS.get(name, "?"))
        holds = result.holds_used.get(name)
        raw = result.raw_units.get(name, "counts")
        head = f"{name}: {cal.method}" + (f", {holds} holds" if holds is not None else "")
        residual_unit = "rad per move" if name == "gyro" else unit   # gyro: rotation misfit of each move
        residual_unit = cal.extra.get("residual_unit", residual_unit)
        head += f", residual_rms {cal.residual_rms:.3g} {residual_unit}, {cal.iterations} iterations"
        if "sample_model" in cal.extra:
            head += f", samples read as {cal.extra['sample_model']}"
            if len(cal.extra.get("misfit_rad_by_sample_model", ())) == 1:
                head += " (the moves fit within their noise)"
        if "move_samples" in cal.extra:
            head += f", with {cal.extra['move_samples']} samples of the moves"
        if not cal.converged:
            head += " (NOT converged)"
        lines.append(head)
        lines.append(f"  B = {vec(cal.B)} {raw}" + (f" +/- {vec(cal.B_std)}" if cal.B_std is not None else ""))
        H_std = np.asarray(cal.H_std) if cal.H_std is not None else None
        for i, row in enumerate(np.asarray(cal.H)):
            label = "  H = " if i == 0 else "      "
            lines.append(label + vec(row) + (f" +/- {vec(H_std[i])}" if H_std is not None else "")
                         + (f"  {unit} per {raw.removesuffix('s') if raw == 'counts' else raw}" if i == 0 else ""))
        if "lever_arm_m" in cal.extra:
            verdict = "significant" if cal.extra.get("lever_arm_significant") else "not significant, not applied"
            verdict += f", p = {cal.extra.get('lever_arm_p_value', float('nan')):.2g}"
            lines.append(f"  lever arm r = {vec(cal.extra['lever_arm_m'])} m +/- {vec(cal.extra['lever_arm_std_m'])}"
                         f" ({verdict}, {cal.extra.get('lever_arm_rows')} move rows)")
        if "dip_std_deg" in cal.extra:
            lines.append(f"  dip {cal.extra['dip_deg']:.3f} +/- {cal.extra['dip_std_deg']:.2g} deg (the field's angle "
                         f"below the horizon, from {len(cal.extra.get('poses', []))} still poses)")
        if cal.g_sensitivity is not None:
            g = cal.g_sensitivity
            lines.append(f"  g-sensitivity {g.deg_s_per_g:.3g} deg/s per g (p = {g.p_value:.2g}, {g.poses} poses): "
                         "taken into the calibration, g_sensitivity in calibration.json")
    return lines
