"""Whether a recording is one pose held (a still log: an Allan-variance run, a unit left on the bench): what
`rig noise` reads, and what the twin of a still log replays (`rig.noise.still_log`)."""

from __future__ import annotations

import numpy as np

from rig.session_data import SessionData

STILL_RATIO = 10.0     # a still stream's spread is its white noise and slow drifts; a moved one's is the motion


def sample_noise(stream: np.ndarray) -> float | np.ndarray:
    """The sample-to-sample noise of a stream (n,) or of each column of (n, k): the Allan deviation at one sample,
    over the samples that are there. White noise's spread; a drift of the bias, which raises a long stream's spread,
    hardly moves it."""
    x = np.asarray(stream, dtype=float)
    if x.ndim == 2:
        return np.array([sample_noise(column) for column in x.T])
    x = x[np.isfinite(x)]
    return float(np.sqrt(0.5 * np.mean(np.diff(x) ** 2))) if len(x) > 1 else 0.0


def stillness_ratio(stream: np.ndarray) -> float:
    """A stream's spread over its sample-to-sample noise: about 1 for white noise, a few for slow drifts, hundreds
    where it moved."""
    x = np.asarray(stream, dtype=float)
    x = x[np.isfinite(x)]
    step = sample_noise(x)
    spread = float(np.std(x)) if len(x) else 0.0
    return spread / step if step > 0 else (0.0 if spread == 0 else np.inf)


def moving_axis(session: SessionData) -> tuple[str, str, float] | None:
    """(sensor, axis, ratio) of the first axis whose spread is more than STILL_RATIO times its sample-to-sample
    noise; None where the whole recording is one pose held."""
    for sensor, y in session.raw.items():
        for k, axis in enumerate("xyz"):
            ratio = stillness_ratio(y[:, k])
            if ratio > STILL_RATIO:
                return sensor, axis, ratio
    return None
