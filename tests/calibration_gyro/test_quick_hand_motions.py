"""A gyro from hand motions quick for their sample rate is calibrated with a deviation that covers its error.

Hand sessions at 100 Hz (`hand_synth`): quick motions turning 1.5-2.5 deg between samples and set down abruptly,
and slower ones easing in and out, a quiet gyro (1e-4 rad/s a sample, an SI-unit IMU's). The turntable's check of
the integration against the rate noise (`sampling.coarseness`) refuses the quick ones; the turntable-free gyro
states the integration error of its sample rate in H_std instead (`carried_gravity`). Over many seeds the error of
each entry of H, in units of the deviation stated for it, must have an RMS near 1: neither an error the deviation
does not cover nor a deviation so wide it says nothing.
"""

import numpy as np
import pytest

from hand_synth import QUICK, SLOW, hand_session
from rig.calibration.turntable.sampling import MARGIN, Coarseness, HandIntegration, coarseness
from rig.calibration.recordings.turntable_free import calibrate_turntable_free
from rig.calibration.recordings.turntable_free_gyro import still_noise
from rig.session_data import MoveStream

SEEDS = range(16)
OFF = ~np.eye(3, dtype=bool)


def calibrated(seed: int, motions):
    rec = hand_session(seed, motions)
    gyro = calibrate_turntable_free(rec["t"], rec["accel"], rec["gyro"], gravity=9.81)["gyro"]
    return rec, gyro


def refused_by_the_rate_noise(rec: dict, gyro) -> bool:
    """What the turntable's check says of the same motions: step doubling's error against MARGIN times the rate
    noise's angle per motion."""
    intervals = [tuple(c) for c in gyro.extra["intervals"]]
    spans = [slice(intervals[i][1], intervals[i + 1][0] + 1) for i in gyro.extra["whole_motions"]]
    moves = [MoveStream(k, rec["t"][s], rec["gyro"][s], np.eye(3), np.eye(3)) for k, s in enumerate(spans)]
    noise = still_noise(rec["gyro"], 0, intervals)
    return coarseness(moves, gyro.B, gyro.H, noise, margin=MARGIN).too_coarse


def rms_z(pairs) -> tuple[float, float]:
    z = np.array([(gyro.H - rec["Hg"]) / gyro.H_std for rec, gyro in pairs])
    return float(np.sqrt(np.mean(z[:, ~OFF] ** 2))), float(np.sqrt(np.mean(z[:, OFF] ** 2)))


@pytest.fixture(scope="module")
def quick():
    return [calibrated(seed, QUICK) for seed in SEEDS]


def test_quick_motions_the_rate_noise_check_refuses_are_calibrated_with_a_warning(quick):
    refused = [refused_by_the_rate_noise(rec, gyro) for rec, gyro in quick]
    assert sum(refused) >= len(quick) * 3 // 4, "the premise: these are the motions the rate noise's check refuses"
    for rec, gyro in quick:
        worst = gyro.extra["integration"]["worst_step_deg"]
        assert 1.0 < worst < 2.6, worst
        assert any(w.startswith("quick motions for the sample rate") for w in gyro.warnings), gyro.warnings
        assert gyro.extra["integration"]["stated_rel"] > gyro.extra["integration"]["stated_rel_without"]


def test_quick_motions_state_a_deviation_that_covers_their_error(quick):
    diagonal, off = rms_z(quick)
    assert 0.7 < diagonal < 1.35 and 0.7 < off < 1.35, (diagonal, off)


def test_slower_motions_state_a_deviation_that_covers_their_error_without_a_warning():
    slow = [calibrated(seed, SLOW) for seed in SEEDS]
    for rec, gyro in slow:
        assert gyro.extra["integration"]["worst_step_deg"] < 1.2
        assert not any(w.startswith("quick motions") for w in gyro.warnings), gyro.warnings
    diagonal, off = rms_z(slow)
    assert 0.7 < diagonal < 1.35 and 0.7 < off < 1.35, (diagonal, off)


def test_a_refusal_says_in_numbers_what_the_fit_could_not_tell():
    """Two limits: a deviation stated beyond HAND_TOLD_REL, and step doubling's error beyond HAND_MARGIN times the
    deviation stated (the fit's account of the rate between samples no longer holds); each refusal names the
    rotation between samples and the figure that broke the limit."""
    found = Coarseness(worst_deg=12.0, error_rad=2e-3, noise_rad=1e-4, limit_deg=1.0, motions=19, angle_rad=1.0)
    told = HandIntegration(found, stated_rel=0.08, without_rel=0.07, rate_hz=20.0)
    assert told.refused and "12 deg between two gyro samples (samples at 20 Hz)" in told.refusal()
    assert "tells H only to 8 %" in told.refusal(), told.refusal()
    covered = HandIntegration(found, stated_rel=1e-4, without_rel=8e-5, rate_hz=20.0)
    assert covered.refused and "20 times the 0.01 % of H" in covered.refusal(), covered.refusal()
    within = HandIntegration(found, stated_rel=2.5e-4, without_rel=2e-4, rate_hz=20.0)
    assert not within.refused and within.quick and "2 mrad per motion" in within.warning(), within.warning()
