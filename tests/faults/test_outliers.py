"""One glitched sample (a read of 2^31) costs that sample, counted, not the hold and its two moves; a real
bump is still motion."""

from __future__ import annotations

import numpy as np
import pytest
from stopping import READS_PER_STEP, stopping_factory

from procedures.acquisition import Recording
from procedures.hold_quality import hold_has_motion
from procedures.orchestrator import RigSpec, SessionOrchestrator
from rig.config import load_config
from rig.outliers import isolated_outliers
from rig.pipeline import calibrate_session
from rig.store import SessionStore

SPIKE = (2**31, 0, 0)


def test_gaussian_noise_has_no_outliers_and_a_spike_is_found():
    rng = np.random.default_rng(0)
    for _ in range(200):
        y = rng.normal([100.0, -40.0, 8000.0], [3.0, 0.4, 20.0], (500, 3)).round()
        assert not isolated_outliers(y).any()
        y[123] = SPIKE
        assert np.flatnonzero(isolated_outliers(y)).tolist() == [123]


def test_a_quantised_noiseless_signal_with_a_spike_and_a_burst():
    y = np.tile([12.0, 0.0, -3.0], (400, 1))
    y[7, 2] = -2**31
    assert np.flatnonzero(isolated_outliers(y)).tolist() == [7]
    y[100:130] += np.sin(np.arange(30))[:, None] * 300        # a knock rings over 30 samples: not "isolated"
    assert not isolated_outliers(y).any()


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    folder = tmp_path_factory.mktemp("s") / "s"
    cfg = load_config()
    cfg.schedule.orientations = 10
    SessionOrchestrator(folder, stopping_factory()).start(cfg, RigSpec(True, 2))
    with SessionStore.open(folder) as store:
        return store.to_session_data()


@pytest.mark.parametrize("sensor", ["accel", "gyro", "mag"])
def test_a_spike_in_a_hold_is_set_aside_with_a_count(session, sensor):
    clean = calibrate_session(session, settle_s=0.0)
    raw = session.raw[sensor].copy()
    rows = np.flatnonzero(~session.is_move & (session.step == 5) & ~np.isnan(raw).any(axis=1))
    raw[rows[len(rows) // 2]] = SPIKE
    original, session.raw[sensor] = session.raw[sensor], raw
    try:
        result = calibrate_session(session, settle_s=0.0)
    finally:
        session.raw[sensor] = original
    assert result.excluded_steps == {}
    assert result.holds_used == clean.holds_used
    assert any(w.startswith(f"{sensor}: 1 isolated outlier sample(s) set aside (1 in step 5)") for w in result.warnings)
    assert not any("not used" in w for w in result.warnings if w not in clean.warnings)
    for name, cal in result.sensors.items():
        np.testing.assert_allclose(cal.H, clean.sensors[name].H, rtol=2e-3)


def test_a_spike_during_acquisition_neither_repeats_the_hold_nor_loses_it(tmp_path):
    cfg = load_config()
    cfg.schedule.orientations = 9
    at = 2 * READS_PER_STEP + 200                                 # in the middle of hold 2
    outcome = SessionOrchestrator(tmp_path / "s", stopping_factory(at, "glitch", glitch=SPIKE)).start(
        cfg, RigSpec(True, 3))
    assert outcome.status == "complete", outcome.reason
    with SessionStore.open(tmp_path / "s") as store:
        events = store.events()
    kinds = [e["kind"] for e in events]
    assert "hold-repeated" not in kinds
    outliers = [e["message"] for e in events if e["kind"] == "outlier-samples"]
    assert len(outliers) == 1 and outliers[0].startswith("hold 2: gyro 1 isolated sample")
    assert any("gyro: 1 isolated outlier sample(s) set aside (1 in step 2)" in w for w in outcome.warnings)
    assert not any("excluded" in w or "not used" in w for w in outcome.warnings), outcome.warnings


def test_a_knock_is_still_motion():
    rng = np.random.default_rng(1)
    y = rng.normal([0.0, 0.0, 0.0], 2.0, (500, 3)).round()
    y[200:260] += (400 * np.exp(-np.arange(60) / 15) * np.sin(np.arange(60) * 1.3))[:, None]
    rec = Recording(np.arange(500) / 100, {"gyro": y}, None, None)
    assert hold_has_motion(rec) is not None
    y[200:260] = rng.normal(0.0, 2.0, (60, 3)).round()
    y[230] = SPIKE
    assert hold_has_motion(Recording(np.arange(500) / 100, {"gyro": y}, None, None)) is None
