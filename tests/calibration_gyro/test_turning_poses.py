"""A turn about the vertical between two poses: the accelerometer stays (nearly) still through it and imu_tk's
detector takes both poses and the turn for one; the gyro sees it (`rig.calibration.recordings.gyro_still`)."""

import numpy as np

from gyro_synth import handheld_record, rel_err, rng  # noqa: F401  (fixture)
from rig.calibration.recordings.gyro_still import split_turning, turning_threshold
from rig.calibration.numerics.static_detect import detect_static_intervals, find_initial_rest
from rig.calibration.recordings.turntable_free import calibrate_turntable_free

VERTICAL = (4, 11)          # the moves into poses 5 and 12 turn about the vertical


def test_the_poses_either_side_of_a_turn_about_the_vertical_are_found_apart(rng):
    t, acc, gyr, truth = handheld_record(rng, poses=20, vertical_turns=VERTICAL)
    merged = detect_static_intervals(t, acc, k=6)
    assert len(merged) == truth["poses"] + 1 - len(VERTICAL), "the premise: the accelerometer alone merges them"
    rest = find_initial_rest(t, acc, gyr)
    assert abs(rest.seconds - 50.0) < 1.0, rest
    # the level from the initial rest, and from the poses alone (a record that starts moving)
    for level in (dict(rest_rows=rest.rows), dict(poses=merged)):
        intervals = split_turning(t, gyr, merged, turning_threshold(t, gyr, **level))
        assert len(intervals) == truth["poses"] + 1, level.keys()
        for (a, b), (ra, rb) in zip(intervals, truth["rests"]):
            assert ra - 50 <= a <= ra + 60 and rb - 60 <= b <= rb + 50   # within 0.5-0.6 s of the true rest


def test_the_gyro_calibrated_across_them_is_as_close_as_without_them(rng):
    """Turns 0.5 deg off the vertical (the hand session of seed 5 had 1 deg): the merged pose's gravity is a blend of
    the two, and the motions either side carry it wrong. Sessions of this generator with no such turn (seeds 0-19,
    20 poses) calibrate to 2.0-6.1e-4 of H; with the two turns, 1.8-7.1e-4 cut by the gyro, 8.1-24e-4 without."""
    t, acc, gyr, truth = handheld_record(rng, poses=20, vertical_turns=VERTICAL, tilt_deg=0.5)
    assert len(detect_static_intervals(t, acc, k=10)) < truth["poses"] + 1, "the premise: k = 10 merges them"
    cal = calibrate_turntable_free(t, acc, gyr, k_values=(10,))
    assert len(cal["accel"].extra["intervals"]) < truth["poses"] + 1, "imu_tk's intervals, for the accelerometer"
    assert len(cal["gyro"].extra["intervals"]) == truth["poses"] + 1
    assert rel_err(cal["gyro"].H, truth["Hg"]) < 8e-4
    assert np.abs(cal["gyro"].B - truth["Bg"]).max() < 0.5
