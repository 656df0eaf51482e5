"""Where a move stream is cut: the reference's motion, and the gyro's own when it lags the encoders."""

import numpy as np

from rig.rotations import quat_from_matrix, rot_z
from rig.session_data import MoveStream


def _lagging_move(lag_tau_s: float):
    """A 90 deg turn about z in 1.5 s, sampled at 100 Hz with 1 s of rest either side; the gyro reports it
    through a first-order low-pass of time constant lag_tau_s (counts = 100 per rad/s, bias 20)."""
    t = np.arange(0.0, 3.5, 0.01)
    s = np.clip((t - 1.0) / 1.5, 0, 1)
    angle = np.pi / 2 * (s - np.sin(2 * np.pi * s) / (2 * np.pi))
    rate = np.gradient(angle, t)
    lagged = np.zeros_like(rate)
    for k in range(1, len(t)):
        lagged[k] = lagged[k - 1] + (rate[k] - lagged[k - 1]) * (1 - np.exp(-0.01 / lag_tau_s))
    y = 20.0 + 100.0 * np.column_stack([np.zeros_like(t), np.zeros_like(t), lagged])
    q = quat_from_matrix(np.array([rot_z(a) for a in angle]))
    return MoveStream(0, t, y, rot_z(0.0), rot_z(np.pi / 2), q)


def test_a_lagging_gyro_keeps_its_tail():
    move = _lagging_move(0.08)
    by_reference = move.trimmed_to_motion()
    by_both = move.trimmed_to_motion(rest=np.full(3, 20.0), still_counts=np.full(3, 0.5))
    integrated = lambda m: np.sum(0.5 * np.diff(m.t) * (m.y[1:, 2] + m.y[:-1, 2] - 40.0)) / 100.0
    assert abs(integrated(by_reference) - np.pi / 2) > 5e-3         # the tail cut off: 0.35 deg
    assert abs(integrated(by_both) - np.pi / 2) < 5e-4              # what is left below the threshold
    assert by_both.t[-1] > by_reference.t[-1]


def test_a_still_gyro_does_not_widen_the_cut():
    move = _lagging_move(0.001)
    by_reference = move.trimmed_to_motion()
    by_both = move.trimmed_to_motion(rest=np.full(3, 20.0), still_counts=np.full(3, 0.5))
    assert abs(by_both.t[0] - by_reference.t[0]) <= 0.011 and abs(by_both.t[-1] - by_reference.t[-1]) <= 0.011
