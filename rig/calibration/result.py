"""The result of calibrating one sensor triad: `u = H (y - B)`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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

    def apply(self, y: np.ndarray) -> np.ndarray:
        """Calibrated values `H (y - B)` for raw rows y (n, 3)."""
        return (np.asarray(y, dtype=float) - self.B) @ self.H.T

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
        d.update({k: v for k, v in self.extra.items() if k not in d})
        return d
