"""A sensor's calibration as a function of die temperature: `u = H(T) (y - B(T))`.

Input: one calibration per temperature step of a thermal session (`ThermalStep`: the step's die temperature,
its spread, and the step's `TriadCalibration` with the deviations of B and H). Each of B's 3 and H's 9 elements
is a polynomial in (T - T_ref), T_ref the middle of the steps' range ((coldest + hottest) / 2: the point where
the coefficients are least correlated), its order chosen by held-out temperatures (polynomial.py), all fitted
by generalised least squares over the steps' covariances (curves.py). The model holds from the coldest to
the hottest step (`valid_c`); applying it outside is refused by name (`TemperatureOutOfRange`, an input
error: exit 2), never extrapolated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.thermal.curves import TermCurves, fit_terms, step_covariance
from rig.errors import InputError

FORMAT_VERSION = 1
H_GROUPS = [[0, 4, 8], [1, 2, 3, 5, 6, 7]]   # H row-major: the scales (diagonal) share one order, the cross-axes one
MODEL_TEXT = "u = H(T) (y - B(T)); each element of B and H (row-major) is sum_j c_j (T - reference_c)^j"


class TemperatureOutOfRange(InputError):
    """A temperature-aware calibration asked to apply where its model was not fitted."""

    def __init__(self, sensor: str, temp_c: float, valid_c: tuple[float, float]) -> None:
        self.sensor, self.temp_c, self.valid_c = sensor, float(temp_c), valid_c
        super().__init__(f"sensor {sensor!r}: die temperature {self.temp_c:.2f} C is outside the temperature "
                         f"model's range {valid_c[0]:.2f} .. {valid_c[1]:.2f} C; the calibration is not applied "
                         "outside the temperatures it was fitted at")


class TemperatureModelFormatError(ValueError):
    """A `temperature_model` object breaks its format; `key` is the sub-key of the first thing wrong."""

    def __init__(self, key: str, message: str) -> None:
        self.key, self.message = key, message
        super().__init__(f"{key}: {message}")


@dataclass
class ThermalStep:
    """One temperature step of a thermal session: the die temperature of its holds (mean, and the deviation
    of that mean), and the calibration made from them."""

    temp_c: float
    calibration: TriadCalibration
    temp_std_c: float = 0.0


@dataclass
class ThermalModel:
    """One sensor's B(T) and H(T) (module docstring); `format_version` is that of its calibration.json key."""

    sensor: str
    reference_c: float
    valid_c: tuple[float, float]
    B: TermCurves
    H: TermCurves
    steps: int
    format_version: int = FORMAT_VERSION

    def check_range(self, temp_c) -> None:
        t = np.atleast_1d(np.asarray(temp_c, dtype=float))
        lo, hi = self.valid_c
        bad = ~((t >= lo) & (t <= hi))
        if bad.any():
            raise TemperatureOutOfRange(self.sensor, float(t[np.flatnonzero(bad)[0]]), self.valid_c)

    def B_at(self, temp_c: float) -> np.ndarray:
        self.check_range(temp_c)
        return self.B.values(float(temp_c) - self.reference_c)[0]

    def H_at(self, temp_c: float) -> np.ndarray:
        self.check_range(temp_c)
        return self.H.values(float(temp_c) - self.reference_c)[0].reshape(3, 3)

    def calibration_at(self, temp_c: float) -> TriadCalibration:
        """The calibration at one temperature, with the covariance of B (3x3) and of H (9x9) the model gives it."""
        dt = float(temp_c) - self.reference_c
        B, H = self.B_at(temp_c), self.H_at(temp_c)
        B_cov, H_cov = self.B.covariance_at(dt), self.H.covariance_at(dt)
        return TriadCalibration(B=B, H=H, method="temperature_model", B_cov=B_cov, H_cov=H_cov,
                                B_std=np.sqrt(np.diag(B_cov)), H_std=np.sqrt(np.diag(H_cov)).reshape(3, 3),
                                extra={"temp_c": float(temp_c)})

    def apply_at(self, y: np.ndarray, temp_c) -> np.ndarray:
        """`H(T) (y - B(T))` for raw rows y (n, 3), T one temperature or one per row; refused (by name) where a
        temperature lies outside `valid_c`."""
        y = np.atleast_2d(np.asarray(y, dtype=float))
        t = np.broadcast_to(np.asarray(temp_c, dtype=float), (y.shape[0],))
        self.check_range(t)
        dt = t - self.reference_c
        B = self.B.values(dt)
        H = self.H.values(dt).reshape(-1, 3, 3)
        return np.einsum("nij,nj->ni", H, y - B)

    def to_json_dict(self) -> dict:
        """The `sensors.<s>.temperature_model` object (docs/reference/calibration-json.md)."""
        return {"format_version": self.format_version, "model": MODEL_TEXT,
                "reference_c": float(self.reference_c), "valid_c": [float(v) for v in self.valid_c],
                "steps": int(self.steps),
                "B": _curves_json(self.B), "H": _curves_json(self.H)}

    @classmethod
    def from_json_dict(cls, sensor: str, d: dict) -> "ThermalModel":
        """Read the key back; a `TemperatureModelFormatError` names the sub-key of the first thing wrong."""
        if not isinstance(d, dict):
            raise TemperatureModelFormatError("temperature_model", "must be an object")
        version = d.get("format_version")
        if version != FORMAT_VERSION:
            raise TemperatureModelFormatError("format_version", f"this reader knows {FORMAT_VERSION}, got {version!r}")
        ref = _finite(d.get("reference_c"), "reference_c")
        valid = d.get("valid_c")
        if not (isinstance(valid, list) and len(valid) == 2):
            raise TemperatureModelFormatError("valid_c", f"must be [lowest, highest] in C, got {valid!r}")
        lo, hi = _finite(valid[0], "valid_c"), _finite(valid[1], "valid_c")
        if not lo <= hi:
            raise TemperatureModelFormatError("valid_c", f"lowest {lo} above highest {hi}")
        return cls(sensor=sensor, reference_c=ref, valid_c=(lo, hi), B=_curves_from_json(d.get("B"), 3, "B"),
                   H=_curves_from_json(d.get("H"), 9, "H"), steps=_count(d.get("steps")), format_version=version)


def fit_thermal_model(sensor: str, steps: list[ThermalStep], *, orders: dict[str, list[int]] | None = None
                      ) -> ThermalModel:
    """Fit one sensor's temperature model to its steps (module docstring). `orders` ({"B": [3], "H": [9]})
    fixes the orders instead of choosing them (a model told the true curve's orders)."""
    if len(steps) < 2:
        raise ValueError(f"sensor {sensor!r}: a temperature model needs calibrations at 2 or more temperatures, "
                         f"got {len(steps)}")
    T = np.array([s.temp_c for s in steps], dtype=float)
    if not np.isfinite(T).all() or np.unique(T).size < len(T):
        raise ValueError(f"sensor {sensor!r}: step temperatures must be finite and distinct, got {T.tolist()}")
    t_std = np.array([s.temp_std_c for s in steps], dtype=float)
    ref = 0.5 * (T.min() + T.max())
    dt = T - ref
    what = f"sensor {sensor!r}"
    ZB = np.stack([np.asarray(s.calibration.B, dtype=float) for s in steps])
    ZH = np.stack([np.asarray(s.calibration.H, dtype=float).reshape(9) for s in steps])
    CB = np.stack([step_covariance(s.calibration.B_cov, s.calibration.B_std, 3, f"{what}, step at {s.temp_c} C, B")
                   for s in steps])
    CH = np.stack([step_covariance(s.calibration.H_cov, s.calibration.H_std, 9, f"{what}, step at {s.temp_c} C, H")
                   for s in steps])
    B = fit_terms(dt, ZB, CB, t_std, None if orders is None else list(orders["B"]))
    H = fit_terms(dt, ZH, CH, t_std, None if orders is None else list(orders["H"]), groups=H_GROUPS)
    return ThermalModel(sensor=sensor, reference_c=float(ref), valid_c=(float(T.min()), float(T.max())),
                        B=B, H=H, steps=len(steps))


def _curves_json(c: TermCurves) -> dict:
    return {"order": [int(p) for p in c.orders], "coefficients": [np.asarray(x).tolist() for x in c.coefficients],
            "covariance": c.covariance.tolist()}


def _curves_from_json(d, terms: int, key: str) -> TermCurves:
    if not isinstance(d, dict):
        raise TemperatureModelFormatError(key, "must be an object with order, coefficients and covariance")
    orders = d.get("order")
    if not (isinstance(orders, list) and len(orders) == terms
            and all(isinstance(p, int) and not isinstance(p, bool) and 0 <= p for p in orders)):
        raise TemperatureModelFormatError(f"{key}.order", f"must be {terms} non-negative integers, got {orders!r}")
    coeffs = d.get("coefficients")
    if not (isinstance(coeffs, list) and len(coeffs) == terms):
        raise TemperatureModelFormatError(f"{key}.coefficients", f"must be {terms} lists, one per term")
    out = []
    for i, (p, c) in enumerate(zip(orders, coeffs)):
        if not (isinstance(c, list) and len(c) == p + 1):
            raise TemperatureModelFormatError(f"{key}.coefficients[{i}]", f"order {p} needs {p + 1} numbers, got {c!r}")
        out.append(np.array([_finite(x, f"{key}.coefficients[{i}]") for x in c]))
    q = sum(p + 1 for p in orders)
    try:
        cov = np.array(d.get("covariance"), dtype=float)
    except (TypeError, ValueError):
        cov = None
    if cov is None or cov.shape != (q, q) or not np.isfinite(cov).all():
        raise TemperatureModelFormatError(f"{key}.covariance",
                                          f"must be a {q}x{q} matrix of numbers (all coefficients, in term order)")
    if (np.diag(cov) < 0).any():
        raise TemperatureModelFormatError(f"{key}.covariance", "a variance is negative")
    return TermCurves(orders=list(orders), coefficients=out, covariance=cov)


def _finite(x, key: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not np.isfinite(x):
        raise TemperatureModelFormatError(key, f"must be a finite number, got {x!r}")
    return float(x)


def _count(x) -> int:
    return x if isinstance(x, int) and not isinstance(x, bool) and x >= 0 else 0
