"""The deviations the norm-only accelerometer fit states (`rig.calibration.numerics.norm_fit_cov`) against its errors on
hand sessions with a known truth: the z = (estimate - truth) / stated of B, H's diagonal and H's upper off-diagonal.

The fit's H is upper triangular (imu_tk's convention: no rotation is seen without known orientations), so the truth
is brought to it: Ha = Q R with R upper triangular and a positive diagonal gives |Ha x| = |R x| for every x, and R
is what the fit estimates. Each pose has, beside the white noise, an offset of its own (a hand's placement, what the
model misses), which the samples' noise does not show and only the scatter of the poses does.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_unseen_recordings import G, recording  # noqa: E402

from rig.calibration.numerics.norm_fit_cov import stated_uncertainty  # noqa: E402
from rig.calibration.recordings.turntable_free import fit_accel_upper  # noqa: E402

POSE_OFFSET = 0.03          # m/s^2 per axis, three times the samples' noise in a pose mean of 100


def upper_truth(Ha: np.ndarray) -> np.ndarray:
    _, R = np.linalg.qr(Ha)
    return np.diag(np.sign(np.diag(R))) @ R


def z_scores(seed: int, poses: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """z of B (3,), of H's diagonal (3,) and of its upper off-diagonal (3,) for one session."""
    rec = recording(seed, poses=poses)
    rng = np.random.default_rng(seed + 1000)
    chunks = [rec["accel"][rec["pose"] == k][:100] + rng.normal(0, POSE_OFFSET, 3) for k in range(poses)]
    B, H, _ = fit_accel_upper(chunks, G)
    spread, _, _ = stated_uncertainty(chunks, B, H, G)
    zH = (H - upper_truth(rec["Ha"])) / np.where(spread["H_std"] > 0, spread["H_std"], np.inf)
    return (B - rec["Ba"]) / spread["B_std"], np.diag(zH), zH[np.triu_indices(3, 1)]


def test_the_stated_deviations_match_the_errors_of_twenty_pose_sessions():
    z = np.array([z_scores(seed, 20) for seed in range(40)])        # (seed, part, axis)
    rms = np.sqrt(np.mean(z ** 2, axis=(0, 2)))
    assert np.all((rms > 0.7) & (rms < 1.4)), dict(zip(("B", "H diagonal", "H off-diagonal"), rms))


def test_ten_poses_state_deviations_that_cover_the_errors_as_one_sigma_does():
    # One degree of freedom: the residuals' variance is a chi-square of one, and the estimate over it is Student's
    # t with one (Cauchy): no RMS of z is finite, so the share of |z| < 1 is what the deviation can be held to.
    z = np.array([z_scores(seed, 10) for seed in range(60)])
    covered = float(np.mean(np.abs(z) < 1))
    assert 0.6 < covered < 0.85, covered
