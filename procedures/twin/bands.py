"""The band a statistic of the real recording is set beside: the replicas' 1-99 %, as order statistics, and the
chance that a statistic the twin gets right falls outside it, which the family test counts against."""

from __future__ import annotations

import numpy as np


def bands(replicas: list[dict], lo: float = 1.0, hi: float = 99.0, min_share: float = 0.8) -> dict[str, tuple]:
    """Per statistic, the replicas' lo..hi band and median (statistics most replicas have). The band's ends are
    order statistics (`band_rank`), not interpolated percentiles: a statistic the twin gets right then falls
    outside with probability 2k/(m+1) whatever its distribution (`band_chance`), the rate the family test assumes;
    numpy's interpolated 1-99 % of 40 replicas lies inside their range and left 6.2 % of such statistics outside,
    not the 4.9 % counted as chance, so a clean recording looked wrong and families were called off."""
    names = {k for r in replicas for k in r}
    out = {}
    for name in names:
        values = np.sort([r[name] for r in replicas if name in r and np.isfinite(r[name])])
        m = len(values)
        if m and m >= min_share * len(replicas):
            k_lo, k_hi = band_rank(m, lo), band_rank(m, 100.0 - hi)
            out[name] = (float(values[k_lo - 1]), float(values[m - k_hi]), float(np.median(values)))
    return out


def band_rank(m: int, percent: float) -> int:
    """The rank k (1-based, from the nearer end) of the order statistic that bounds a `percent` tail of m draws:
    the largest k whose chance k/(m+1) of a new draw falling beyond it is at most `percent`, at least 1."""
    return max(1, int(np.floor(percent / 100.0 * (m + 1) + 1e-9)))


BAND_REPLICAS = 99          # the fewest whose extremes are the 1-99 % band itself (chance 1/(n+1) = 1 % a side)
FEWEST_REPLICAS = 40        # below, the family test's chance per statistic (2/41 = 4.9 %) leaves it little power
ROW_REPLICAS = 2_000_000    # rows x replicas that keep a whole analysis within its 30 s on two cores (the Xsens's
# 51 175 rows at 40 replicas; benchmarks/bench_twin.py measures it)


def default_replicas(rows: int) -> int:
    """How many replicas a recording of `rows` rows is set beside: the 1-99 % band's own 99 where the time target
    allows (a 10 000-row recording in about 11 s), fewer for a longer one, down to 40, whose band is then its range
    (2.4-97.6 %: stricter than the 1-99 % the analysis names, and so are the counts inside it)."""
    return int(min(BAND_REPLICAS, max(FEWEST_REPLICAS, ROW_REPLICAS // max(rows, 1))))


def band_chance(m: int, lo: float = 1.0, hi: float = 99.0) -> float:
    """The chance that a statistic the twin gets right falls outside the `bands` of m replicas."""
    return (band_rank(m, lo) + band_rank(m, 100.0 - hi)) / (m + 1)
