"""The white noise and rounding of a twin's replicas, as the recording shows them: each sensor's noise level pooled
over the recording's static poses, how many degrees of freedom that estimate has, the level one replica draws
from it, the level of the poses a hand left alone, and the decimals a recording in physical units was printed
with. Apart from the replay's motion (`procedures.twin_replay`): these say how the recording's noise looks, not
where the fixture was."""

from __future__ import annotations

import zlib
from collections.abc import Iterable

import numpy as np

from rig.calibration.quantisation import noise_sigma
from rig.calibration.recording import RecordingCalibration
from rig.io.decimals import written_decimals
from rig.noise.rounding import noise_sigma_at
from rig.noise.still import sample_noise
from rig.noise.still_log import is_still_log_calibration
from rig.session_data import SessionData


def white_noise(session: SessionData, sensor: str, rec: RecordingCalibration) -> np.ndarray:
    """Per-axis standard deviation of the noise ahead of the rounding (raw units), pooled over the poses: what the
    simulator's white noise is. A recording in counts was rounded after its noise, and so is every replica, so the
    rounding's own share is taken out here (quantisation.noise_sigma) rather than counted twice."""
    stds, n = _pose_spreads(session, rec, sensor)
    stds = stds[n > 1]
    if session.meta.get("units", {}).get(sensor, "counts") == "counts":
        return noise_sigma(stds)
    return np.sqrt(np.mean(stds ** 2, axis=0))


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
    spreads, n = _pose_spreads(session, rec, sensor)
    still_log = is_still_log_calibration(rec)
    if quiet and not still_log and (n > 1).sum() > 1:
        return _quiet_pool_dof(spreads[n > 1], n[n > 1])
    weights = _quiet(spreads, n) * (n[:, None] - 1) if quiet else np.ones(spreads.shape)
    return _pooled_dof(n, weights, still_log)


def _quiet_pool_dof(spreads: np.ndarray, n: np.ndarray, draws: int = 2000) -> np.ndarray:
    """Per axis, 2 / the relative variance of the quiet level as `quiet_spread` finds it, in poses drawn again:
    the quiet ones at their pooled level, the others at their own spread, each pose's variance a chi-square of its
    samples. Counted from the quiet poses' samples alone, the degrees of freedom were 1.4-1.8 times too many on six
    equal white poses (`test_noise_level_dof`): a pose is in the pool where its spread came out low."""
    near = _quiet(spreads, n)
    m = (n - 1.0)[:, None]
    level = np.sum(near * m * spreads ** 2, axis=0) / np.sum(near * m, axis=0)
    truth = np.where(near, level, spreads ** 2)
    rng = np.random.default_rng(0x51DE)
    drawn = truth * rng.chisquare(np.broadcast_to(m, truth.shape), size=(draws,) + truth.shape) / m
    error = 1.0 / np.sqrt(2.0 * n)
    least = np.argmin(drawn, axis=1)
    lowest = np.take_along_axis(drawn, least[:, None, :], axis=1)
    bound = lowest * (1.0 + 2.0 * np.sqrt(error[least][:, None, :] ** 2 + error[None, :, None] ** 2)) ** 2
    w = (drawn <= bound) * m
    pooled = np.sum(w * drawn, axis=1) / np.sum(w, axis=1)
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


def printed_decimals(session: SessionData, sensors: Iterable[str]) -> dict[str, int]:
    """Sensors in physical units whose every value has at most d decimals: the file the recording came from was
    printed so (a CSV export), and its replicas are printed alike. Without it the value step of a stream written
    with 6 decimals is 1e-6 in the recording and a fraction of that in the replicas' unrounded values, and the
    twin named quantisation on every such sensor of a clean recording."""
    units = session.meta.get("units", {})
    found = {s: written_decimals(session.raw[s]) for s in sensors if units.get(s, "counts") != "counts"}
    return {s: d for s, d in found.items() if d is not None}


def quiet_poses(session: SessionData, rec: RecordingCalibration, sensor: str) -> np.ndarray:
    """(poses, 3) which poses are quiet on each axis: those within twice their sampling error (a white spread's,
    1/sqrt(2n) of it) of the quietest. A hand can only add to the sensor's own noise, and how many poses it leaves
    alone is the recording's: on mikoff's MPU-9150s 3-6 of 22, so their lower quartile, the level taken before,
    was a held pose's and put the quiet poses below every replica."""
    return _quiet(*_pose_spreads(session, rec, sensor))


def quiet_spread(session: SessionData, rec: RecordingCalibration, sensor: str) -> np.ndarray:
    """Per axis, the spread of the quiet poses (`quiet_poses`), raw units, rounding included: their variances pooled
    by degrees of freedom, the common level's best estimate. Their median had let a short pose's spread stand for a
    long rest's: on the MPU-6050 the 36 s rest's short-tau Allan deviations fell below every replica."""
    spreads, n = _pose_spreads(session, rec, sensor)
    near = _quiet(spreads, n)
    return np.sqrt(np.sum(near * (n[:, None] - 1) * spreads ** 2, axis=0) / np.sum(near * (n[:, None] - 1), axis=0))


def _pose_spreads(session: SessionData, rec: RecordingCalibration, sensor: str) -> tuple[np.ndarray, np.ndarray]:
    """Each pose's spread per axis (poses, 3) and its samples. A still log's one pose is held for minutes or hours,
    and its spread is its drift's as much as its noise's: its noise is its sample-to-sample noise (the drift is a
    cause of its own, `rate_random_walk` or `bias_instability`)."""
    poses = [sampled_rows(session.raw[sensor][p.rows]) for p in rec.poses]
    spread = sample_noise if is_still_log_calibration(rec) else (lambda v: v.std(axis=0, ddof=1))
    return np.array([spread(v) for v in poses]), np.array([len(v) for v in poses])


def _quiet(spreads: np.ndarray, n: np.ndarray) -> np.ndarray:
    error = 1.0 / np.sqrt(2.0 * n)
    least = np.argmin(spreads, axis=0)
    bound = spreads[least, range(3)] * (1.0 + 2.0 * np.sqrt(error[least][None, :] ** 2 + error[:, None] ** 2))
    return spreads <= bound


def quiet_noise(session: SessionData, rec: RecordingCalibration, sensor: str,
                q: np.ndarray | None = None) -> np.ndarray:
    """Per axis, the quiet poses' spread (`quiet_spread`): the sensor's own noise, which the poses where a hand shook
    cannot lower; ahead of the rounding (counts, or the step `q` of a quantised recording)."""
    spreads, n = _pose_spreads(session, rec, sensor)
    return _ahead_of_rounding(session, rec, sensor, q, spreads, n, _quiet(spreads, n) * (n[:, None] - 1))


def pooled_noise(session: SessionData, rec: RecordingCalibration, sensor: str, q: np.ndarray | None) -> np.ndarray:
    """Per axis, the noise pooled over the poses (each pose's variance alike), ahead of the rounding."""
    spreads, n = _pose_spreads(session, rec, sensor)
    return _ahead_of_rounding(session, rec, sensor, q, spreads, n, np.ones(spreads.shape))


def _ahead_of_rounding(session: SessionData, rec: RecordingCalibration, sensor: str, q: np.ndarray | None,
                       spreads: np.ndarray, n: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The Gaussian noise that, rounded to the step (1 count, or `q`), shows the poses' `spreads` (poses, 3; `n`
    samples each), their variances pooled with `weights` (poses, 3): given where each pose's mean sits on the grid
    (`rig.noise.rounding.noise_sigma_at`; the replicas' poses sit where the recording's do), up to two steps of
    spread. Beyond, and where no noise gives the poses their spreads, the mean over all places (`noise_sigma`), or
    below half a step the spread itself.

    Counts in steps of 8 under 3 counts of noise (a still log: one pose) had given its replicas 3.4-3.6 counts
    ahead of their rounding from the mean over all places, whose spread after it put 29 of the log's statistics
    outside that the plain twin had inside."""
    spread = np.sqrt(np.sum(weights * spreads ** 2, axis=0) / np.sum(weights, axis=0))
    if q is None and session.meta.get("units", {}).get(sensor, "counts") == "counts":
        q = np.ones(3)
    if q is None:
        return spread
    q = np.where(q > 0, q, 1.0)
    sigma = np.where(spread >= 0.5 * q, noise_sigma((spread / q)[None, :]) * q, spread)
    means = np.array([sampled_rows(session.raw[sensor][p.rows]).mean(axis=0) for p in rec.poses])
    for k in np.flatnonzero(spread < 2.0 * q):        # beyond, the two agree, and the levels would be thousands
        use = (weights[:, k] > 0) & (n > 1)
        found = noise_sigma_at(means[use, k], spreads[use, k] ** 2, weights[use, k], float(q[k])) if use.any() else None
        sigma[k] = sigma[k] if found is None else found
    return sigma


def sampled_rows(v: np.ndarray) -> np.ndarray:
    """The rows of v (n, 3) where every axis has a sample."""
    return v[~np.isnan(v).any(axis=1)]
