"""The white noise and rounding of a twin's replicas, as the recording shows them: each sensor's noise level pooled
over the recording's static poses and the level of the poses a hand left alone (how precisely those levels are known,
and what one replica draws from them: `procedures.twin.draws`). Apart from the replay's motion
(`procedures.twin.replay`): these say how the recording's noise looks, not where the fixture was."""

from __future__ import annotations


import numpy as np

from rig.calibration.numerics.quantisation import noise_sigma
from rig.calibration.recordings.recording import RecordingCalibration
from rig.noise.rounding import noise_sigma_at
from rig.noise.still import sample_noise
from rig.noise.still_log import is_still_log_calibration
from rig.session_data import SessionData


def white_noise(session: SessionData, sensor: str, rec: RecordingCalibration) -> np.ndarray:
    """Per-axis standard deviation of the noise ahead of the rounding (raw units), pooled over the poses: what the
    simulator's white noise is. A recording in counts was rounded after its noise, and so is every replica, so the
    rounding's own share is taken out here (quantisation.noise_sigma) rather than counted twice."""
    stds, n = pose_spreads(session, rec, sensor)
    stds = stds[n > 1]
    if session.meta.get("units", {}).get(sensor, "counts") == "counts":
        return noise_sigma(stds)
    return np.sqrt(np.mean(stds ** 2, axis=0))


def quiet_poses(session: SessionData, rec: RecordingCalibration, sensor: str) -> np.ndarray:
    """(poses, 3) which poses are quiet on each axis: those within twice their sampling error (a white spread's,
    1/sqrt(2n) of it) of the quietest. A hand can only add to the sensor's own noise, and how many poses it leaves
    alone is the recording's: on mikoff's MPU-9150s 3-6 of 22, so their lower quartile, the level taken before,
    was a held pose's and put the quiet poses below every replica."""
    return quiet_mask(*pose_spreads(session, rec, sensor))


def quiet_spread(session: SessionData, rec: RecordingCalibration, sensor: str) -> np.ndarray:
    """Per axis, the spread of the quiet poses (`quiet_poses`), raw units, rounding included: their variances pooled
    by degrees of freedom, the common level's best estimate. Their median had let a short pose's spread stand for a
    long rest's: on the MPU-6050 the 36 s rest's short-tau Allan deviations fell below every replica."""
    return np.sqrt(quiet_variance(*pose_spreads(session, rec, sensor)))


def quiet_variance(spreads: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(..., 3) the quiet poses' variances pooled by degrees of freedom, for spreads (..., poses, 3) of n samples each
    (a stack of recordings drawn again: `procedures.twin.draws`)."""
    w = quiet_mask(spreads, n) * (n[:, None] - 1.0)
    return np.sum(w * spreads ** 2, axis=-2) / np.sum(w, axis=-2)


def pose_spreads(session: SessionData, rec: RecordingCalibration, sensor: str) -> tuple[np.ndarray, np.ndarray]:
    """Each pose's spread per axis (poses, 3) and its samples. A still log's one pose is held for minutes or hours,
    and its spread is its drift's as much as its noise's: its noise is its sample-to-sample noise (the drift is a
    cause of its own, `rate_random_walk` or `bias_instability`)."""
    poses = [sampled_rows(session.raw[sensor][p.rows]) for p in rec.poses]
    spread = sample_noise if is_still_log_calibration(rec) else (lambda v: v.std(axis=0, ddof=1))
    return np.array([spread(v) for v in poses]), np.array([len(v) for v in poses])


def quiet_mask(spreads: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Which of spreads (..., poses, 3) are quiet (`quiet_poses`)."""
    error = 1.0 / np.sqrt(2.0 * n)
    least = np.argmin(spreads, axis=-2)
    lowest = np.take_along_axis(spreads, least[..., None, :], axis=-2)
    return spreads <= lowest * (1.0 + 2.0 * np.sqrt(error[least][..., None, :] ** 2 + error[:, None] ** 2))


def quiet_noise(session: SessionData, rec: RecordingCalibration, sensor: str,
                q: np.ndarray | None = None) -> np.ndarray:
    """Per axis, the quiet poses' spread (`quiet_spread`): the sensor's own noise, which the poses where a hand shook
    cannot lower; ahead of the rounding (counts, or the step `q` of a quantised recording)."""
    spreads, n = pose_spreads(session, rec, sensor)
    return _ahead_of_rounding(session, rec, sensor, q, spreads, n, quiet_mask(spreads, n) * (n[:, None] - 1))


def pooled_noise(session: SessionData, rec: RecordingCalibration, sensor: str, q: np.ndarray | None) -> np.ndarray:
    """Per axis, the noise pooled over the poses (each pose's variance alike), ahead of the rounding."""
    spreads, n = pose_spreads(session, rec, sensor)
    return _ahead_of_rounding(session, rec, sensor, q, spreads, n, np.ones(spreads.shape))


def _ahead_of_rounding(session: SessionData, rec: RecordingCalibration, sensor: str, q: np.ndarray | None,
                       spreads: np.ndarray, n: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The Gaussian noise that, rounded to the step (1 count, or `q`), shows the poses' `spreads` (poses, 3; `n`
    samples each), their variances pooled with `weights` (poses, 3): given where each pose's mean sits on the grid
    (`rig.noise.rounding.noise_sigma_at`; the replicas' poses sit where the recording's do), up to two steps of
    spread. Beyond, and where no noise gives the poses their spreads, the mean over all places (`noise_sigma`), or
    below half a step the spread itself.

    Where the pose's mean sits on the grid matters when the noise is small against the step: counts in steps of 8
    under 3 counts of noise spread very differently at a step's middle and at its edge, so the mean over all places
    would give the replicas too much noise."""
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
