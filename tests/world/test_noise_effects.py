"""The noise and recording terms of the simulated world, at the level of the quantities they disturb."""

from __future__ import annotations

import numpy as np

from fixtures.world.effects.noise import HoldNotStill
from fixtures.world.effects_base import Context


def _context(t: np.ndarray) -> Context:
    n = len(t)
    return Context(t=t, R=np.tile(np.eye(3), (n, 1, 1)), f=np.zeros((n, 3)), omega=np.zeros((n, 3)),
                   angles=np.zeros((n, 2)), rates=np.zeros((n, 2)), temp=np.full(n, 25.0), supply=np.full(n, 3.3))


def test_a_pose_not_still_tilts_the_accelerometer_by_the_turn_its_gyro_measures_and_only_within_the_envelope():
    """One motion seen by both sensors: gravity, as the accelerometer reads it, turns by the integral of the rate
    the gyro reads, and a stretch where the envelope's gain is nil (a motion the twin replays from the recording)
    neither turns it nor carries its wander into the next pose. The accelerometer's tilt had been the ungated
    wobble's integral times the gain: nil between the poses, and in the second pose off by the wander of the gap."""
    t = np.arange(0.0, 8.0, 0.001)
    envelope = ((-np.inf, np.inf, np.zeros(3)), (1.0, 2.0, np.ones(3)), (6.0, 7.0, np.array([1.0, 0.5, 2.0])))
    gyro = HoldNotStill("gyro", rms_dps=3.0, tau_s=0.05, envelope=envelope, seed=11)
    accel = HoldNotStill("accel", rms_dps=3.0, tau_s=0.05, envelope=envelope, seed=11)
    gravity = np.tile([0.0, 0.0, 9.80665], (len(t), 1))
    rate = gyro.input(_context(t), np.zeros((len(t), 3)))
    tilt = accel.input(_context(t), gravity) - gravity

    turned = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (rate[1:] + rate[:-1]) * 0.001, axis=0)])
    expected = np.cross(gravity, turned)
    assert np.abs(expected).max() > 1e-3                              # the wobble turns gravity measurably
    # to the wobble's own grid (tau / 10) at the envelope's edges: 2.6 % here; the ungated integral was 116 % off
    assert np.abs(tilt - expected).max() < 0.05 * np.abs(expected).max(), np.abs(tilt - expected).max()
    gap = (t > 2.1) & (t < 5.9)
    assert np.abs(rate[gap]).max() == 0.0
    assert np.ptp(tilt[gap], axis=0).max() < 1e-12 and np.abs(tilt[gap]).max() > 1e-4
