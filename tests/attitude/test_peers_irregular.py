"""The ahrs peers on rows that are not on one period (multi-rate sessions, jitter, gaps)."""

import numpy as np
import pytest
from attitude_synth import make_motion, rms_error_deg

import rig.attitude.peers as peers
from rig.attitude.noise import SensorNoise
from rig.rotations import quat_from_matrix

NOISE = SensorNoise(0.004, 0.012, 0.15)
DIP = 60.0


def _enu_start(m):
    # the peers' navigation frame: magnetic ENU; the synthetic field points north (y) and down
    return quat_from_matrix(m.R[0])


def _run(name, m, rows):
    return peers.run_peer(name, m.t[rows], m.gyro[rows], m.accel[rows], m.mag[rows], noise=NOISE, gravity=9.80665,
                          field_uT=50.0, dip_deg=DIP, q0_enu=_enu_start(m))


@pytest.fixture(scope="module")
def motion():
    return make_motion(seed=3, mag_every=1)


@pytest.mark.parametrize("name", ["madgwick", "mahony", "ekf", "ekf-defaults"])
def test_row_by_row_equals_the_batch_mode_on_a_fixed_period(motion, name, monkeypatch):
    rows = np.arange(600)
    batch = _run(name, motion, rows)
    monkeypatch.setattr(peers, "irregular", lambda t: True)
    assert np.abs(_run(name, motion, rows) - batch).max() < 1e-6


def test_multi_rate_rows_are_integrated_over_their_own_interval(monkeypatch):
    # rows at the union of a 200 Hz and an 80 Hz sensor (on a 400 Hz base): steps of 2.5 and 5 ms
    m = make_motion(seed=3, rate_hz=400.0, mag_every=1)
    k = np.arange(len(m.t))
    rows = np.flatnonzero((k % 2 == 0) | (k % 5 == 0))
    assert peers.irregular(m.t[rows])
    R_true = m.R[rows]
    ours = rms_error_deg(R_true, _run("ekf", m, rows))
    monkeypatch.setattr(peers, "irregular", lambda t: False)        # what the batch mode's one period did
    fixed = rms_error_deg(R_true, _run("ekf", m, rows))
    assert np.sqrt(np.sum(ours ** 2)) < 0.3
    assert np.sqrt(np.sum(fixed ** 2)) > 3 * np.sqrt(np.sum(ours ** 2))


def test_jitter_is_irregular_and_a_fixed_period_is_not():
    t = 1.7e9 + np.arange(1000) * 0.01          # Unix time: rounding makes the steps differ by ~1e-7 s
    assert not peers.irregular(t)
    assert peers.irregular(t + np.random.default_rng(0).uniform(-5e-4, 5e-4, t.size))
