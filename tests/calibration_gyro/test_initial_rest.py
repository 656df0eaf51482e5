"""The initial rest of a hand-held record, found in the data (`static_detect.find_initial_rest`), and a record that
starts moving calibrated from its poses (`turntable_free`, `turntable_free_gyro`)."""

import numpy as np
import pytest

from gyro_synth import handheld_record, rel_err
from rig.calibration.numerics.static_detect import find_initial_rest, window_samples
from rig.calibration.recordings.turntable_free import calibrate_turntable_free


@pytest.mark.parametrize("rest_s", [7.0, 50.0])
def test_a_rest_of_7_or_50_s_is_found_to_within_its_last_window(rest_s):
    """The rest ends half a window before the first motion's first window: within 1 s of the true rest, never past
    it, on every seed; the calibration then takes its bias from those rows."""
    for seed in range(4):
        t, acc, gyr, truth = handheld_record(np.random.default_rng(seed), poses=14, rest_s=rest_s)
        rest = find_initial_rest(t, acc, gyr)
        moves_at = truth["rests"][0][1] + 1                   # the first moving row
        assert rest.origin == "found" and moves_at - 100 <= rest.rows <= moves_at, (seed, rest, moves_at)
        assert rest_s - 1.0 <= rest.seconds <= rest_s, (seed, rest)


def test_a_turn_about_the_vertical_ends_the_rest_where_the_accelerometer_alone_would_not():
    """The first move turns about the vertical: gravity stays put in the body, the accelerometer stays still through
    it and only the gyro shows the rest ending."""
    t, acc, gyr, truth = handheld_record(np.random.default_rng(3), poses=14, rest_s=20.0, vertical_turns=(0,))
    moves_at = truth["rests"][0][1] + 1
    blind = find_initial_rest(t, acc)
    assert blind.rows > moves_at + 100, "the premise: the accelerometer alone runs on past the turn"
    rest = find_initial_rest(t, acc, gyr)
    assert moves_at - 100 <= rest.rows <= moves_at, (rest, moves_at)


def test_a_gyro_noisier_in_its_first_seconds_than_later_still_rests():
    """mikoff's MPU-9150 reads 70-260 times the variance in its first 7 s that it reads in its later poses; the rest
    is judged by its own gyro level, not by the quietest stretches of the record."""
    t, acc, gyr, truth = handheld_record(np.random.default_rng(5), poses=14, rest_s=7.0)
    first = t < 7.0
    gyr = gyr.copy()
    gyr[first] += np.random.default_rng(0).normal(0, 10 * gyr[first].std(axis=0), (first.sum(), 3))
    rest = find_initial_rest(t, acc, gyr)
    assert rest.origin == "found" and 6.0 <= rest.seconds <= 7.0, rest


def test_a_rest_said_overrides_the_one_found():
    t, acc, gyr, _ = handheld_record(np.random.default_rng(1), poses=14, rest_s=50.0)
    rest = find_initial_rest(t, acc, gyr, given_s=30.0)
    assert rest.origin == "given" and rest.seconds == 30.0 and rest.rows == int(np.searchsorted(t - t[0], 30.0))


def test_a_record_that_starts_moving_is_calibrated_from_its_poses():
    """No rest at all: the static threshold from the quietest stretches, the gyro's bias from the poses' still
    stretches, and both say so; the result as close to the truth as a record with a rest gets (the imu_tk-like
    tests: accel 1e-3, gyro 2e-3 of H, bias within half a count)."""
    for seed in range(3):
        t, acc, gyr, truth = handheld_record(np.random.default_rng(20 + seed), poses=24, rest_s=0.0)
        rest = find_initial_rest(t, acc, gyr)
        assert rest.origin == "none" and rest.rows == 0, rest
        cal = calibrate_turntable_free(t, acc, gyr)
        a, g = cal["accel"], cal["gyro"]
        assert a.extra["initial_rest"] == "none" and any("no initial rest" in w for w in a.warnings), a.warnings
        assert g.extra["bias_from"] == "poses" and any("no initial rest: bias from the poses" in w
                                                       for w in g.warnings), g.warnings
        assert len(a.extra["intervals"]) == truth["poses"], seed
        assert rel_err(a.H, truth["Ha"]) < 1e-3 and rel_err(g.H, truth["Hg"]) < 2e-3, seed
        assert np.abs(g.B - truth["Bg"]).max() < 0.5, (g.B - truth["Bg"], g.B_std)
        assert (np.abs(g.B - truth["Bg"]) < 4 * g.B_std).all(), (g.B - truth["Bg"], g.B_std)


def test_a_record_shorter_than_two_windows_of_rest_starts_moving():
    """A still start of one window is too short to be a rest (its gyro level would rest on one window mean)."""
    t, acc, gyr, _ = handheld_record(np.random.default_rng(2), poses=14, rest_s=1.0)
    assert window_samples(t, 1.0) == 101
    assert find_initial_rest(t, acc, gyr).origin == "none"
