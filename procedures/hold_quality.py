"""What a hold's samples say about the hold: isolated outlier samples (kept in the record, logged, set aside by the
statistics), motion during it (someone bumped the table), the standard error of its mean, and the sequential
hold's target built on that standard error. The sampler (`procedures.acquisition`) records a hold; this judges it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from procedures.acquisition import Recording
from procedures.protocols import Store
from procedures.slots import triad_kind
from rig.outliers import OUTLIER_SIGMAS, isolated_outliers


def log_outliers(store: Store, step: int, rec: Recording) -> None:
    """Say in the session log which sensors of a stored hold had isolated outlier samples (they stay recorded)."""
    found = hold_outliers(rec)
    if found:
        store.log_event("outlier-samples", f"hold {step}: " + ", ".join(f"{name} {n}" for name, n in found.items())
                        + f" isolated sample(s) further than {OUTLIER_SIGMAS:g} robust sigmas from the hold's "
                        "median; kept in the record, set aside by the hold statistics", float(rec.t[-1]))


def hold_outliers(rec: Recording) -> dict[str, int]:
    """Isolated outlier samples per sensor of a hold (kept in the record; set aside by the statistics)."""
    out = {}
    for name, y in rec.samples.items():
        n = int(isolated_outliers(y[~np.isnan(y).any(axis=1)]).sum())
        if n:
            out[name] = n
    return out


def hold_has_motion(rec: Recording, *, window_s: float = 0.5, rate_hz: float = 100.0, k_sigma: float = 8.0,
                    k_std: float = 4.0, quantum: float = 2.0) -> str | None:
    """Says which sensor and axis moved during a hold (someone bumped the table), or None.

    The hold is cut into windows. A static hold has window means that agree to within their standard
    error (plus a couple of counts of quantisation) and window spreads alike; a slow drift shows in the
    means, a knock (a fast, decaying oscillation that averages out) in one window's spread. An isolated
    outlier sample (a read glitch, `rig.outliers`) is not motion: it is set aside before the windows are
    judged (`hold_outliers` counts them), while a knock rings over too many samples to be set aside.
    """
    n_win = max(int(window_s * rate_hz), 2)
    for name in [n for kind in ("gyro", "accel") for n in rec.samples if triad_kind(n) == kind]:
        y = rec.samples[name]
        y = y[~np.isnan(y).any(axis=1)]
        y = y[~isolated_outliers(y)]
        m = len(y) // n_win
        if m < 3:
            continue
        w = y[: m * n_win].reshape(m, n_win, 3)
        means, stds = w.mean(axis=1), w.std(axis=1)
        typical = np.median(stds, axis=0)
        se = typical / np.sqrt(n_win)
        spread = means.max(axis=0) - means.min(axis=0)
        ratio = stds.max(axis=0) / (typical + quantum / 2)
        for axis in range(3):
            if spread[axis] > k_sigma * se[axis] + quantum:
                return (f"{name} {'xyz'[axis]}: window means spread {spread[axis]:.1f} counts "
                        f"(limit {k_sigma * se[axis] + quantum:.1f})")
            if ratio[axis] > k_std:
                return (f"{name} {'xyz'[axis]}: a window's spread is {ratio[axis]:.1f} times the hold's typical "
                        f"(limit {k_std})")
    return None


QUANTUM_COUNTS = 1.0    # raw samples are whole counts


def mean_standard_error(y: np.ndarray, quantum: float = QUANTUM_COUNTS) -> np.ndarray:
    """Standard error (3,) of the mean of a hold's samples y (n, 3), per axis, counting what white-noise
    arithmetic would miss: quantisation, as `quantum^2 / 12` more variance per sample (a spread of a count or
    less does not average away like white noise), and correlation between samples, through the effective
    sample count of an AR(1) noise, `n (1 - rho) / (1 + rho)`, where the lag-1 autocorrelation rho is beyond
    its chance level 2 / sqrt(n) (white noise then keeps its n). Outlier samples (`rig.outliers`) are set aside."""
    y = np.asarray(y, dtype=float)
    y = y[~np.isnan(y).any(axis=1)]
    if len(y) < 8:
        return np.full(3, np.inf)
    y = y[~isolated_outliers(y)]
    n = len(y)
    d = y - y.mean(axis=0)
    var = np.mean(d * d, axis=0)
    rho = np.divide(np.mean(d[1:] * d[:-1], axis=0), var, out=np.zeros(3), where=var > 0)
    rho = np.where(rho > 2 / np.sqrt(n), np.minimum(rho, 0.99), 0.0)
    n_eff = n * (1 - rho) / (1 + rho)
    return np.sqrt((var * n / (n - 1) + quantum**2 / 12) / n_eff)


@dataclass
class HoldTarget:
    """Sequential holds: a hold ends once the standard error of every static sensor's mean
    (`mean_standard_error`, worst axis) is what the plan asked, between `min_s` and `max_s`. The plan asks for
    the standard error that `hold_s` seconds give at the unit's own noise: the first hold of a run is held for
    `hold_s` and sets each sensor's target; later holds end as soon as they have it, a noisier or correlated
    hold (a draught, a vibrating floor) runs longer, up to `max_s`. A sensor's standard error is the RMS over
    its axes, and it has what it needs within twice the sampling spread of that estimate (1 / sqrt(6 n) of it for
    n samples): white noise ends its holds at `hold_s`, rather than wherever chance first favours them all."""

    hold_s: float
    min_s: float
    max_s: float
    sensors: tuple[str, ...] = ("accel", "mag", "gyro")
    target: dict[str, float] = field(default_factory=dict)

    def done(self, rec_samples: dict[str, np.ndarray], elapsed_s: float) -> bool:
        """Whether the hold recorded so far (`rec_samples`, `elapsed_s` seconds of it) can end."""
        if elapsed_s >= self.max_s - 1e-9:
            return True
        if not self.target:
            return elapsed_s >= self.hold_s - 1e-9
        if elapsed_s < self.min_s - 1e-9:
            return False
        return all(_rms_se(rec_samples[s]) <= self.target[s] * (1 + 2 / np.sqrt(6 * max(_count(rec_samples[s]), 1)))
                   for s in self.target if s in rec_samples)

    def learn(self, rec_samples: dict[str, np.ndarray]) -> None:
        """The first full hold's standard errors are the targets of the holds after it."""
        if not self.target:
            self.target = {s: _rms_se(rec_samples[s]) for s in self.sensors
                           if s in rec_samples and np.isfinite(_rms_se(rec_samples[s]))}


def _rms_se(y: np.ndarray) -> float:
    return float(np.sqrt(np.mean(mean_standard_error(y) ** 2)))


def _count(y: np.ndarray) -> int:
    return int((~np.isnan(y).any(axis=1)).sum())
