"""How a recording in physical units was written, read from its values, and the same done to every replica of its
twin: the recording's own step (its print resolution or its storage's), not a rounding of the twin's.

A CSV export prints values with d decimals (every value on a grid of 10^-d: `rig.io.decimals`); C's `%g` and many
loggers print n significant digits (a value of 9.8 on a grid of 1e-5, one of 0.05 on 1e-7); a logger that keeps
single-precision floats stores values on float32's grid (9.5e-7 between 8 and 16 m/s^2, 4.8e-7 between 4 and 8).
Each leaves the stream's value step at its own resolution, and replicas in full precision show a step set only by
how densely their values lie (3-7e-5 m/s^2 on a hand recording): the step was outside its band on every such
recording, and the twin, taking the smallest decimals every value has for the file's print, rounded its replicas to
a grid of its own (8 decimals for a `%.6g` print, whose values near zero carry that many).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from rig.io.decimals import written_decimals
from rig.session_data import SessionData

MAX_DIGITS = 12           # a float printed in full needs 16-17 significant digits; fewer is a print's
TOLERANCE = 1e-3          # of a step: a value read from a print is on its grid to ~1e-10 of a step
FLOAT32_TOLERANCE = 0.1   # of float32's spacing: a float32 printed with 9 significant digits reads back within 8.4 % of it
PROBE = 4096              # values a form is tried on before all of them are


@dataclass(frozen=True)
class Printed:
    """One written form: "decimals" (`places` after the point), "digits" (`places` significant) or "float32"."""

    kind: str
    places: int = 0

    def apply(self, y: np.ndarray) -> None:
        """Write the values of y (any shape) in this form, in place (NaN stays NaN)."""
        if self.kind == "decimals":
            np.round(y, self.places, out=y)
        elif self.kind == "digits":
            scale = _digit_scale(y, self.places)
            with np.errstate(invalid="ignore"):
                np.divide(np.round(y * scale), scale, out=y, where=np.isfinite(scale))
        else:
            y[...] = y.astype(np.float32)

    def step_at(self, value: float) -> float:
        """The form's resolution at `value`."""
        if self.kind == "decimals":
            return 10.0 ** -self.places
        if self.kind == "digits":
            return float(1.0 / _digit_scale(np.array([value]), self.places)[0])
        return float(np.spacing(np.float32(abs(value))))

    def describe(self) -> str:
        return {"decimals": f"{self.places} decimals", "digits": f"{self.places} significant digits",
                "float32": "single-precision floats"}[self.kind]


def printed_forms(session: SessionData, sensors: Iterable[str]) -> dict[str, Printed]:
    """The written form of each sensor of `sensors` in physical units whose values have one (`printed_form`)."""
    units = session.meta.get("units", {})
    found = {s: printed_form(session.raw[s]) for s in sensors if units.get(s, "counts") != "counts"}
    return {s: form for s, form in found.items() if form is not None}


def printed_form(values: np.ndarray) -> Printed | None:
    """The form every finite value of the stream was written in, or None (full precision, or counts times a scale
    printed in full, whose grid is the sensor's own quantisation). Single precision first (a float32 printed with 9
    digits also has 9 significant digits, but its grid is float32's); then d decimals or n significant digits,
    whichever is the coarser at the stream's typical magnitude (5 decimals of values up to 9.8 are also 6
    significant digits, and the decimals' 1e-5 is then the grid; a `%.6g` print of the same values needs 8 or more
    decimals for its smallest, and its 6 digits are the grid)."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return None
    if _fits(x, _on_float32):
        return Printed("float32")
    decimals = written_decimals(x)
    digits = next((n for n in range(1, MAX_DIGITS + 1) if _fits(x, lambda v, n=n: _on_digits(v, n))), None)
    if digits is None:
        return None if decimals is None else Printed("decimals", decimals)
    by_digits = Printed("digits", digits)
    if decimals is None:
        return by_digits
    typical = float(np.median(np.abs(x[x != 0]))) if (x != 0).any() else 1.0
    return by_digits if by_digits.step_at(typical) > 10.0 ** -decimals * (1 + 1e-9) else Printed("decimals", decimals)


def _fits(x: np.ndarray, on_grid) -> bool:
    """Every value on the form's grid: tried on a probe first, so a stream in full precision is refused at once."""
    return bool(on_grid(x[:PROBE]).all()) and bool(on_grid(x).all())


def _on_float32(x: np.ndarray) -> np.ndarray:
    single = x.astype(np.float32)
    return np.abs(x - single.astype(float)) <= FLOAT32_TOLERANCE * np.spacing(np.abs(single)).astype(float)


def _on_digits(x: np.ndarray, n: int) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        scaled = x * _digit_scale(x, n)
    near = np.abs(scaled - np.round(scaled)) <= TOLERANCE * np.maximum(1.0, 1e-12 * np.abs(scaled))
    return near | (x == 0)


def _digit_scale(x: np.ndarray, n: int) -> np.ndarray:
    """10^(n - 1 - floor(log10 |x|)): x times it has n digits before the point (inf at 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return 10.0 ** (n - 1 - np.floor(np.log10(np.abs(x))))
