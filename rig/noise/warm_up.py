"""A warm-up at the start of a still record: the bias settling as the unit comes to temperature, which the Allan
deviation of the whole record reads as bias instability and rate random walk.

Two shapes are tried, each with its own time `tau`: an exponential settling, bias += a exp(-t / tau), and a ramp
that ends, bias += a (1 - t / tau) until tau. For a given tau both are linear in the level and `a`, so the best
tau of each is found on a grid and refined (scipy's bounded scalar search), on the stream averaged in blocks.

A fitted shape is a warm-up when the start stands off the settled level by more than the settled record ever
wanders: the mean of the first tau differs from the settled level by `MIN_STAND_OFF` times the range of the
means of tau-long windows over the settled part (at least five of them: tau is at most an eighth of the record).
A stationary noise (white, a flicker floor, a Gauss-Markov bias, a random walk) wanders as much later in the
record as at its start, and is not named; a trend that has not settled within the record (its best tau, searched
up to half the record, longer than an eighth) cannot be told from one and is not named either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar, nnls

EXPONENTIAL, RAMP = "exponential", "ramp"
MAX_BLOCKS = 2000           # the stream is averaged to at most this many blocks for the fit
FINEST_BLOCK_S = 0.05       # the blocks of the first search, over the first MAX_BLOCKS of them
MIN_BLOCKS = 40
LONGEST_FRACTION = 1 / 8    # tau at most this part of the record: five taus of settled record after three
SEARCHED_FRACTION = 1 / 2   # taus searched: a trend whose best tau is longer than the longest named has not settled
SETTLED_AFTER = 3.0         # taus of an exponential after which its remnant (5 %) no longer moves the settled level
MIN_STAND_OFF = 3.0         # the start's offset from the settled level over the settled record's range
REMNANT = 0.1               # the analysis starts where what is left of the trend is this part of the noise's wander
REPLICAS = 40               # refits that give the deviations of a and tau


@dataclass
class WarmUp:
    shape: str                 # EXPONENTIAL or RAMP
    a: float                   # unit of the stream, at the stretch's start (bias offset there from the settled level)
    a_std: float
    tau_s: float               # exponential: the time constant; ramp: its end
    tau_std: float
    settled_s: float           # from the stretch's start: where the analysis of the settled stream begins
    stand_off: float           # the start's offset over the settled record's range (evidence, >= MIN_STAND_OFF)

    def trend(self, t: np.ndarray) -> np.ndarray:
        return self.a * _shape(self.shape, np.asarray(t, dtype=float), self.tau_s)

    def to_dict(self) -> dict:
        return {"shape": self.shape, "a": self.a, "a_std": self.a_std, "tau_s": self.tau_s, "tau_s_std": self.tau_std,
                "settled_s": self.settled_s, "stand_off": self.stand_off}


def _shape(shape: str, t: np.ndarray, tau: float) -> np.ndarray:
    return np.exp(-t / tau) if shape == EXPONENTIAL else np.clip(1.0 - t / tau, 0.0, None)


def _blocks(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    size = max(1, math.ceil(len(x) / MAX_BLOCKS))
    n = len(x) // size * size
    return t[:n].reshape(-1, size).mean(axis=1), x[:n].reshape(-1, size).mean(axis=1)


def _linear(tb: np.ndarray, xb: np.ndarray, shape: str, tau: float) -> tuple[float, np.ndarray]:
    """Residual sum of squares and (level, a) of the shape at tau."""
    A = np.column_stack([np.ones_like(tb), _shape(shape, tb, tau)])
    coef, *_ = np.linalg.lstsq(A, xb, rcond=None)
    r = xb - A @ coef
    return float(r @ r), coef


def _best_tau(tb: np.ndarray, xb: np.ndarray, shape: str, lo: float, hi: float,
              points: int = 48) -> tuple[float, float]:
    """The tau in [lo, hi] whose shape fits best, and its residual sum of squares: a log-spaced grid, refined."""
    grid = np.geomspace(lo, hi, points)
    rss = [_linear(tb, xb, shape, tau)[0] for tau in grid]
    k = int(np.argmin(rss))
    a, b = math.log(grid[max(k - 1, 0)]), math.log(grid[min(k + 1, len(grid) - 1)])
    if b > a:
        found = minimize_scalar(lambda s: _linear(tb, xb, shape, math.exp(s))[0], bounds=(a, b), method="bounded",
                                options={"xatol": 1e-4})
        if found.fun <= rss[k]:
            return math.exp(found.x), float(found.fun)
    return float(grid[k]), float(rss[k])


def _deviations(tb: np.ndarray, xb: np.ndarray, shape: str, level: float, a: float, tau: float, lo: float,
                hi: float, settled_s: float) -> tuple[float, float]:
    """Standard deviations of a and tau over replicas: the fitted trend plus noise drawn like the record's own
    where it has settled (white and random walk at the sizes its Allan variance shows: `_noise_model`), fitted
    again. A random walk under the trend moves the fit as independent blocks would not."""
    trend = level + a * _shape(shape, tb, tau)
    white, walk = _noise_model((xb - trend)[tb >= settled_s])
    rng = np.random.default_rng(len(tb))
    found = []
    for _ in range(REPLICAS):
        again = trend + white * rng.standard_normal(len(tb)) + np.cumsum(walk * rng.standard_normal(len(tb)))
        tau_again, _ = _best_tau(tb, again, shape, max(lo, tau / 4), min(hi, tau * 4), points=12)
        found.append((_linear(tb, again, shape, tau_again)[1][1], tau_again))
    a_found, tau_found = np.array(found).T
    return float(np.std(a_found, ddof=1)), float(np.std(tau_found, ddof=1))


def _noise_model(noise: np.ndarray) -> tuple[float, float]:
    """Per block: the standard deviation of a white noise and of the steps of a random walk whose sum has the
    Allan variance of `noise` over octave clusters of blocks (the discrete walk's over m blocks is
    q^2 (2 m^2 + 1) / (6 m)). Non-negative least squares, each point weighted by the model's Allan variance over
    the square root of its clusters (its relative error), the model's once there is one: weights from the
    measured values make a point that came out low, as one of few clusters may, pull the whole model down."""
    sizes = [m for m in 2 ** np.arange(12) if len(noise) // m >= 4]
    avar, count = [], []
    for m in sizes:
        means = noise[: len(noise) // m * m].reshape(-1, m).mean(axis=1)
        avar.append(0.5 * np.mean(np.diff(means) ** 2))
        count.append(len(means) - 1)
    m, avar = np.array(sizes, dtype=float), np.array(avar)
    A = np.column_stack([1 / m, (2 * m ** 2 + 1) / (6 * m)])
    model = avar
    for _ in range(3):
        w = np.sqrt(np.array(count, dtype=float)) / np.maximum(model, 1e-300)
        (white2, walk2), _ = nnls(A * w[:, None], avar * w)
        if not white2 + walk2 > 0:
            break
        model = A @ np.array([white2, walk2])
    return math.sqrt(white2), math.sqrt(walk2)


def _window_means(t: np.ndarray, x: np.ndarray, start: float, width: float) -> np.ndarray:
    """The means of x over consecutive windows of `width` seconds from `start` (those holding a sample)."""
    index = np.searchsorted(t, np.arange(start, t[-1] + 1e-12, width))
    index = np.unique(index[index < len(x)])
    if len(index) < 2:
        return np.zeros(0)
    sums = np.add.reduceat(x[index[0]:], index - index[0])
    counts = np.diff(np.r_[index, len(x)])
    return (sums / counts)[:-1]                                    # the last window runs past the final edge


def find_warm_up(t: np.ndarray, x: np.ndarray) -> WarmUp | None:
    """The warm-up at the start of a still stream x (n,) at times t (s, from the stretch's start), or None (module
    docstring). The start is searched first in fine blocks (`FINEST_BLOCK_S`) over as much of it as `MAX_BLOCKS`
    of them cover, then in blocks four times as long over four times as much, up to the whole stream: a warm-up of
    seconds at the start of hours is resolved, and one of an hour still seen."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    keep = np.isfinite(x)
    t, x = t[keep], x[keep]
    if len(x) < MIN_BLOCKS or np.ptp(x) == 0:
        return None
    block = FINEST_BLOCK_S
    while MAX_BLOCKS * block < t[-1] - t[0]:
        rows = t - t[0] <= MAX_BLOCKS * block
        found = _found_in(t[rows], x[rows], t, x)
        if found is not None:
            return found
        block *= 4
    return _found_in(t, x, t, x)


def _found_in(t: np.ndarray, x: np.ndarray, t_all: np.ndarray, x_all: np.ndarray) -> WarmUp | None:
    """The warm-up fitted to the start (t, x) of the stream (t_all, x_all) in at most `MAX_BLOCKS` blocks, and
    judged against the whole stream's settled part (module docstring)."""
    if len(x) < MIN_BLOCKS or np.ptp(x) == 0:
        return None
    tb, xb = _blocks(t, x)
    record = float(t[-1] - t[0])
    lo, hi = 3 * float(tb[1] - tb[0]), LONGEST_FRACTION * record
    if hi <= lo:
        return None
    fits = [(shape, *_best_tau(tb, xb, shape, lo, SEARCHED_FRACTION * record)) for shape in (EXPONENTIAL, RAMP)]
    shape, tau, _ = min(fits, key=lambda f: f[2])
    if tau > hi:
        return None
    _, (level, a) = _linear(tb, xb, shape, tau)
    ends = SETTLED_AFTER * tau if shape == EXPONENTIAL else tau
    settled = _window_means(t_all, x_all, ends, tau)
    if len(settled) < 5:
        return None
    start = float(x[t < tau].mean())
    stand_off = abs(start - float(np.median(settled))) / max(float(np.ptp(settled)), 1e-300)
    if stand_off < MIN_STAND_OFF:
        return None
    wander = float(np.sqrt(0.5 * np.mean(np.diff(settled) ** 2)))      # the settled Allan deviation at tau
    if shape == EXPONENTIAL:
        begin = tau * math.log(max(abs(a) / max(REMNANT * wander, 1e-300), 1.0))
        begin = max(begin, SETTLED_AFTER * tau)
    else:
        begin = tau
    a_std, tau_std = _deviations(tb, xb, shape, level, a, tau, lo, hi, ends)
    return WarmUp(shape, float(a), a_std, float(tau), tau_std, float(min(begin, t_all[-1])), float(stand_off))
