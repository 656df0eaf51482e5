"""The result of calibrating one sensor triad: `u = H (y - B)`, and for a gyroscope whose recording showed it, its
g-sensitivity: `u = H (y - B - K (f - f_ref))`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class GSensitivity:
    """A gyroscope's response to specific force (effects.md `gyro_g_sensitivity`), in its raw units: the rate it
    adds is `K (f - f_ref)`, f the calibrated accelerometer (m/s^2) of the same instant. `f_ref` is the specific
    force at which `B` holds (the average over the poses B was taken from), so a reader that knows only
    `u = H (y - B)` keeps the bias it had."""

    K: np.ndarray                      # (3, 3) raw gyro unit per m/s^2
    f_ref: np.ndarray                  # (3,) m/s^2
    p_value: float                     # its nested F test against none
    deg_s_per_g: float                 # the largest singular value of H K, deg/s per g (as effects.md reports it)
    poses: int

    def raw_rate(self, specific_force: np.ndarray) -> np.ndarray:
        """What it adds to raw rows, for the calibrated specific force f (n, 3) of each."""
        return (np.asarray(specific_force, dtype=float) - self.f_ref) @ self.K.T

    def to_json_dict(self) -> dict:
        return {"K": self.K.tolist(), "f_ref_mps2": self.f_ref.tolist(), "p_value": float(self.p_value),
                "deg_s_per_g": float(self.deg_s_per_g), "poses": int(self.poses),
                "model": "u = H (y - B - K (f - f_ref)), f the calibrated accelerometer (m/s^2)"}


@dataclass
class TriadCalibration:
    B: np.ndarray                      # (3,) raw counts
    H: np.ndarray                      # (3, 3) unit per count; det(H) > 0
    method: str
    residual_rms: float = float("nan")  # in calibrated units
    iterations: int = 0
    converged: bool = True
    B_std: np.ndarray | None = None
    H_std: np.ndarray | None = None
    B_cov: np.ndarray | None = None    # (3, 3)
    H_cov: np.ndarray | None = None    # (9, 9), row-major vec(H)
    warnings: list[str] = field(default_factory=list)
    extra: dict = field(default_factory=dict)
    g_sensitivity: GSensitivity | None = None

    def apply(self, y: np.ndarray, specific_force: np.ndarray | None = None) -> np.ndarray:
        """Calibrated values `H (y - B)` for raw rows y (n, 3); with the calibrated specific force of the same rows,
        less the g-sensitivity where the calibration has one (without it: the linear model alone)."""
        y = np.asarray(y, dtype=float)
        if self.g_sensitivity is not None and specific_force is not None:
            y = y - self.g_sensitivity.raw_rate(specific_force)
        return (y - self.B) @ self.H.T

    def to_json_dict(self, unit: str) -> dict:
        d = {"unit": unit, "B": self.B.tolist(), "H": self.H.tolist(), "method": self.method,
             "residual_rms": float(self.residual_rms), "iterations": int(self.iterations),
             "converged": bool(self.converged)}
        if self.B_std is not None:
            d["B_std"] = np.asarray(self.B_std).tolist()
        if self.H_std is not None:
            d["H_std"] = np.asarray(self.H_std).tolist()
        if self.warnings:
            d["warnings"] = list(self.warnings)
        if self.g_sensitivity is not None:
            d["g_sensitivity"] = self.g_sensitivity.to_json_dict()
        d.update({k: v for k, v in self.extra.items() if k not in d})
        return d
