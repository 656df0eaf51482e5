"""How precisely a twin's noise levels are known, and the level each replica draws from them: the degrees of
freedom of each estimate (the plain twin's pooled level, the quiet poses' level, the noise ahead of a rounding) and
the chi-square draw a replica makes with them (`procedures.twin.noise` finds the levels themselves)."""

from __future__ import annotations

import zlib

import numpy as np

from procedures.twin.noise import pose_spreads, quiet_mask, quiet_variance, sampled_rows
from rig.calibration.recordings.recording import RecordingCalibration
from rig.noise.still_log import is_still_log_calibration
from rig.session_data import SessionData


def drawn_level(level: np.ndarray, dof: float | np.ndarray | None, seed: int, stream: int) -> np.ndarray:
    """The replica's white noise level, per axis: the recording's estimate `level`, drawn from what the poses allow it
    to be (sigma^2 ~ nu s^2 / chi^2_nu, nu = `dof`; `stream` keeps each sensor's draw for trial `seed` apart). The
    level is estimated from the recording itself; a replica that took it as known judged the most precise statistics
    (the spread and short-tau Allan deviation of a 50 s rest, pinned to 1.4 %) against a band blind to the 1.1 % by
    which the estimate misses: on clean hand sessions the rest's spreads fell outside 5 times in 45 (3 with the
    draw), the other poses' 34 in 855 (31)."""
    if dof is None or not np.all(np.asarray(dof) > 0):
        return level
    rng = np.random.default_rng((seed, 0x7E1A, stream))
    return level * np.sqrt(dof / rng.chisquare(dof, size=3))


def extension_level(level: np.ndarray, dof: np.ndarray | None, seed: int, sensor: str, part: str) -> np.ndarray:
    """The white noise level an effect of the extension gives a replica in place of the plain twin's, drawn as that
    one is (`drawn_level`), from a stream of its own (`part` of `sensor`). Held at the recording's estimate, the
    extension's replicas had judged a 6-hour log's accelerometer spread against a band blind to the estimate's own
    miss, where the plain twin's were not."""
    return drawn_level(level, dof, seed, zlib.crc32(f"{sensor} {part}".encode()))


def noise_dof(session: SessionData, sensor: str, rec: RecordingCalibration) -> float | None:
    """The degrees of freedom of `white_noise`'s pooled variance, a plain mean of the poses' variances:
    nu = P^2 / sum(1 / (n_i - 1)) (each variance has 2 sigma^4 / (n_i - 1)). A still log's variance is its
    sample-to-sample one (`sample_noise`), whose consecutive differences share a sample: 3 sigma^4 / n, so two
    thirds of those degrees of freedom. Counted as the spread's, the replicas' level was pinned half as tight again
    as the log's own, and on a 6-hour log, where bands are a tenth of a percent wide, its spread fell outside."""
    n = np.array([len(sampled_rows(session.raw[sensor][p.rows])) for p in rec.poses])
    dof = _pooled_dof(n, np.ones((len(n), 3)), is_still_log_calibration(rec))
    return None if dof is None else float(dof[0])


def level_dof(session: SessionData, rec: RecordingCalibration, sensor: str, quiet: bool) -> np.ndarray | None:
    """(3,) degrees of freedom of `quiet_noise`'s level (`quiet`) or `pooled_noise`'s, as `noise_dof` counts them
    for the plain twin's. Ahead of a rounding they are the spreads' the level was found from. The quiet level's are
    its estimator's own (`_quiet_pool_dof`): which poses count as quiet depends on their spreads."""
    spreads, n = pose_spreads(session, rec, sensor)
    still_log = is_still_log_calibration(rec)
    if quiet and not still_log and (n > 1).sum() > 1:
        return _quiet_pool_dof(spreads[n > 1], n[n > 1])
    weights = quiet_mask(spreads, n) * (n[:, None] - 1) if quiet else np.ones(spreads.shape)
    return _pooled_dof(n, weights, still_log)


def _quiet_pool_dof(spreads: np.ndarray, n: np.ndarray, draws: int = 2000) -> np.ndarray:
    """Per axis, 2 / the relative variance of the quiet level as `quiet_spread` finds it, in poses drawn again:
    the quiet ones at their pooled level, the others at their own spread, each pose's variance a chi-square of its
    samples. Counted from the quiet poses' samples alone, the degrees of freedom were 1.4-1.8 times too many on six
    equal white poses (`test_noise_level_dof`): a pose is in the pool where its spread came out low."""
    m = (n - 1.0)[:, None]
    truth = np.where(quiet_mask(spreads, n), quiet_variance(spreads, n), spreads ** 2)
    rng = np.random.default_rng(0x51DE)
    drawn = truth * rng.chisquare(np.broadcast_to(m, truth.shape), size=(draws,) + truth.shape) / m
    pooled = quiet_variance(np.sqrt(drawn), n)
    return 2.0 / np.maximum((pooled.std(axis=0) / pooled.mean(axis=0)) ** 2, 1e-300)


def _pooled_dof(n: np.ndarray, weights: np.ndarray, still_log: bool) -> np.ndarray | None:
    """Per axis, the degrees of freedom of the poses' variances pooled with `weights` (poses, 3), each variance
    having 2 sigma^4 / (n_i - 1): nu = (sum w_i)^2 / sum(w_i^2 / (n_i - 1)); a still log's two thirds of that."""
    use = n > 1
    w, m = weights[use], (n[use] - 1.0)[:, None]
    if not use.any() or not (w.sum(axis=0) > 0).all():
        return None
    dof = np.sum(w, axis=0) ** 2 / np.sum(w ** 2 / m, axis=0)
    return 2.0 * dof / 3.0 if still_log else dof
