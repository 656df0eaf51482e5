"""The decimals a column of a recording was written with: a logger or a CSV export that prints values in physical
units with d decimals puts every value on a grid of 10^-d, whatever the sensor's own resolution."""

from __future__ import annotations

import numpy as np

MAX_DECIMALS = 9
TOLERANCE = 1e-3          # of a grid step: a float read from d printed decimals is on the grid to ~1e-10 of it


def written_decimals(values: np.ndarray) -> int | None:
    """The fewest decimals d (0..MAX_DECIMALS) that every finite value has, or None: a value the print did not
    round (a stream kept at full precision, or one in counts times a scale such as imucal's 1/16.4 deg/s) has
    none. Random continuous values all on one grid to 1e-3 of a step by chance: 0.002 to the power of the
    samples."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return None
    for d in range(MAX_DECIMALS + 1):
        scaled = x * 10.0 ** d
        if np.all(np.abs(scaled - np.round(scaled)) <= TOLERANCE * np.maximum(1.0, 1e-12 * np.abs(scaled))):
            return d
    return None
