"""`calibrate --from`: a synthetic session with known truth through the real solvers, and bad input."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from io_synthetic import build_session

from rig.errors import CalibrationError, SessionFormatError
from rig.io.calibration_json import read_calibration
from rig.io.session_writer import write_session
from rig.pipeline import calibrate_from_dir, calibrate_session
from rig.pipeline.screening import turning_holds as _turning_holds
from rig.session_data import HoldStats
from tests.paths import DATA

H_REL_TOL = {"accel": 1e-4, "gyro": 2e-3, "mag": 2e-3}
B_TOL_COUNTS = {"accel": 0.5, "gyro": 0.2, "mag": 0.5}


@pytest.fixture(scope="module")
def base():
    return build_session(seed=11, hold_s=2.5)


def fresh(base):
    return copy.deepcopy(base[0]), base[1]


def assert_matches_truth(sensors, truth, names=("accel", "gyro", "mag")):
    for name in names:
        cal = sensors[name]
        rel = np.abs(cal.H - truth.H[name]).max() / np.abs(truth.H[name]).max()
        assert rel < H_REL_TOL[name], (name, rel)
        assert np.abs(cal.B - truth.B[name]).max() < B_TOL_COUNTS[name], (name, cal.B, truth.B[name])


def hold_rows(session, step):
    return dict(session.hold_rows())[step]


def test_from_dir_end_to_end(tmp_path, base):
    session, truth = base
    write_session(session, tmp_path / "session")
    lines = []
    result = calibrate_from_dir(tmp_path / "session", tmp_path / "out", echo=lines.append)
    doc = read_calibration(tmp_path / "out" / "calibration.json")
    assert set(doc["sensors"]) == {"accel", "gyro", "mag"}
    assert (doc["gravity_mps2"], doc["field_uT"]) == (session.gravity, session.field_uT)
    assert doc["source"]["format"] == "imu-session-csv/1" and doc["excluded_steps"] == {}
    np.testing.assert_array_equal(np.array(doc["sensors"]["accel"]["H"]), result.sensors["accel"].H)
    assert_matches_truth(result.sensors, truth)
    text = "\n".join(lines)
    for name in ("accel: joint-ml, 20 holds", "gyro: gyro-ukf", "mag: joint-ml", "B = [", "H = [", "+/-", "wrote "):
        assert name in text
    assert "warning: dropped the first 0.5 s of every hold as settling" in text


def test_two_step_uncertainty_covers_the_error(base):
    session, truth = fresh(base)
    cal = calibrate_session(session).sensors["accel"]
    assert cal.B_std is not None and cal.H_std is not None
    assert (np.abs(cal.B - truth.B["accel"]) < 5 * cal.B_std).all()
    assert (np.abs(cal.H - truth.H["accel"]) < 5 * cal.H_std + 1e-12).all()


def test_joint_method(base):
    session, truth = fresh(base)
    result = calibrate_session(session, method="joint")
    assert result.sensors["accel"].method.startswith("joint")
    assert_matches_truth(result.sensors, truth)


def test_settling_is_dropped(base):
    session, truth = fresh(base)
    for _, idx in session.hold_rows():
        age = session.t[idx] - session.t[idx[0]]
        ring = (age < 0.3)[:, None] * np.array([400.0, -300.0, 500.0])
        session.raw["accel"][idx] += np.round(ring)
    settled = calibrate_session(session, settle_s=0.5)
    assert_matches_truth(settled.sensors, truth, ("accel",))
    raw = calibrate_session(session, settle_s=0.0)
    assert np.abs(raw.sensors["accel"].B - truth.B["accel"]).max() > 10 * B_TOL_COUNTS["accel"]
    assert not any("settling" in w for w in raw.warnings)


def _ring_reference(session, seconds: float, amplitude_deg: float) -> None:
    """The reference (and nothing else) turns about fixture x for `seconds` at the start of every hold."""
    from rig.rotations import matrix_from_quat, quat_from_matrix, rot_x
    for _, idx in session.hold_rows():
        age = session.t[idx] - session.t[idx[0]]
        ring = np.radians(amplitude_deg) * np.where(age < seconds, np.sin(2 * np.pi * 4 * age), 0.0)
        R = matrix_from_quat(session.q_ref[idx]) @ rot_x(ring)
        session.q_ref[idx] = quat_from_matrix(R)


def test_settling_follows_the_reference_beyond_the_fixed_time(base):
    session, _ = fresh(base)
    _ring_reference(session, seconds=0.8, amplitude_deg=0.5)
    starts = {j: session.t[idx[0]] for j, idx in session.hold_rows(0.5)}
    firsts = {j: session.t[idx[0]] for j, idx in session.hold_rows()}
    lags = np.array([starts[j] - firsts[j] for j in starts])
    assert lags.min() >= 0.7 and lags.max() <= 0.85


def test_quiet_reference_keeps_the_fixed_settling_time(base):
    session, _ = fresh(base)
    lags = [session.t[a[0]] - session.t[b[0]] for (_, a), (_, b) in zip(session.hold_rows(0.5), session.hold_rows())]
    assert max(lags) < 0.5 + 0.02


EIGHT = np.array([[0, 0], [45, 67], [90, 134], [135, 201], [180, 268], [225, 335], [270, 42], [315, 109]])


def test_fast_moves_at_a_coarse_sample_rate_are_flagged(base):
    session, _ = build_session(seed=5, hold_s=2.0, rate_hz=50.0, vmax_dps=200.0, accel_dps2=600.0)
    assert any("deg between samples" in w for w in calibrate_session(session).warnings)
    quiet, _ = fresh(base)
    assert not any("deg between samples" in w for w in calibrate_session(quiet).warnings)


def test_too_few_orientations_for_the_two_step_method():
    session, _ = build_session(seed=2, hold_s=1.0, schedule_deg=EIGHT)
    with pytest.raises(CalibrationError, match="8 usable orientations, need at least 9 for the two-step method "
                                               r"\(the joint method needs 6\)"):
        calibrate_session(session, method="two-step")


def test_joint_method_calibrates_eight_orientations(base):
    session, truth = build_session(seed=2, hold_s=2.0, schedule_deg=EIGHT)
    result = calibrate_session(session)
    assert_matches_truth(result.sensors, truth, ("accel", "mag"))


def test_too_few_orientations_for_any_method():
    session, _ = build_session(seed=2, hold_s=1.0, schedule_deg=EIGHT[:5])
    with pytest.raises(CalibrationError, match="5 usable orientations, need at least 6 for the joint method"):
        calibrate_session(session)


def test_coplanar_orientations():
    schedule = np.column_stack([np.arange(0, 360, 30.0), np.zeros(12)])
    session, _ = build_session(seed=2, hold_s=1.0, schedule_deg=schedule, sensors=("accel",))
    with pytest.raises(CalibrationError, match="coplanar: fixture axis x never sees"):
        calibrate_session(session)


def test_gyro_schedule_that_cannot_excite_an_axis():
    schedule = np.column_stack([np.arange(0, 360, 30.0), np.zeros(12)])
    session, _ = build_session(seed=2, hold_s=1.0, schedule_deg=schedule, sensors=("gyro",))
    with pytest.raises(CalibrationError, match="gyro: the moves never rotate about fixture direction"):
        calibrate_session(session)


def test_saturated_hold_excluded(base):
    session, truth = fresh(base)
    idx = hold_rows(session, 3)
    session.raw["accel"][idx[len(idx) // 2:], 2] = 32767
    result = calibrate_session(session)
    assert 3 in result.excluded_steps
    assert any("step 3: excluded, accel axis z at its rail 32767" in w for w in result.warnings)
    assert result.holds_used["accel"] == 19
    assert_matches_truth(result.sensors, truth)


def test_rail_code_without_pile_up_is_not_saturation(base):
    session, _ = fresh(base)
    idx = hold_rows(session, 4)
    session.raw["accel"][idx[5], 0] = 32767       # one spike at the rail code, no clipping plateau
    assert 4 not in calibrate_session(session).excluded_steps


def test_motion_during_hold_flagged(base):
    session, truth = fresh(base)
    idx = hold_rows(session, 5)
    wobble = 300.0 * np.sin(2 * np.pi * 3.0 * session.t[idx])
    session.raw["accel"][idx, 0] += np.round(wobble)
    result = calibrate_session(session)
    assert "accel noise" in result.excluded_steps[5] and "motion during the hold" in result.excluded_steps[5]
    assert list(result.excluded_steps) == [5]
    assert_matches_truth(result.sensors, truth)


def test_gyro_turning_during_hold_flagged(base):
    session, truth = fresh(base)
    idx = hold_rows(session, 7)
    session.raw["gyro"][idx, 1] += 25.0            # a creep of ~1.5 deg/s the encoders did not see
    result = calibrate_session(session)
    assert "the table was turning" in result.excluded_steps[7]
    assert any(w.startswith("gyro: move 7 -> 8 not used") for w in result.warnings)
    assert any(w.startswith("gyro: move 6 -> 7 not used") for w in result.warnings)
    assert_matches_truth(result.sensors, truth)


def test_nan_reference_rows_refused(base):
    session, _ = fresh(base)
    session.q_ref[100] = np.nan
    with pytest.raises(CalibrationError, match="reference quaternion is NaN/inf on 1 row.*first row 100"):
        calibrate_session(session)


def test_sensor_nan_through_a_hold_is_named(base):
    session, truth = fresh(base)
    session.raw["mag"][hold_rows(session, 9)] = np.nan
    result = calibrate_session(session)
    assert any("mag: no samples (NaN) in the hold(s) of step 9" in w for w in result.warnings)
    assert result.holds_used["mag"] == 19 and result.holds_used["accel"] == 20
    assert_matches_truth(result.sensors, truth)


def test_mag_without_field_refused(base):
    session, _ = fresh(base)
    session.field_uT = None
    with pytest.raises(CalibrationError, match="field_uT"):
        calibrate_session(session)


def test_unknown_method_refused(base):
    with pytest.raises(ValueError, match="method"):
        calibrate_session(fresh(base)[0], method="magic")


def test_imu_tk_timestamps_must_agree(tmp_path):
    (tmp_path / "s_acc.txt").write_text("0.0 1 2 3\n0.01 1 2 3\n")
    (tmp_path / "s_gyro.txt").write_text("0.0 1 2 3\n0.02 1 2 3\n")
    with pytest.raises(SessionFormatError, match="s_gyro.txt, line 2, column 'timestamp': time stamps differ"):
        calibrate_from_dir(tmp_path, tmp_path / "out", fmt="imu_tk", echo=lambda s: None)


def test_imu_tk_needs_unambiguous_files(tmp_path):
    (tmp_path / "a_acc.txt").write_text("0.0 1 2 3\n")
    (tmp_path / "b_acc.txt").write_text("0.0 1 2 3\n")
    with pytest.raises(CalibrationError, match="exactly one accel file"):
        calibrate_from_dir(tmp_path, tmp_path / "out", fmt="imu_tk", echo=lambda s: None)


def test_output_is_strict_json_with_warnings(tmp_path, base):
    session, _ = fresh(base)
    session.raw["accel"][hold_rows(session, 3), 2] = 32767
    write_session(session, tmp_path / "s")
    calibrate_from_dir(tmp_path / "s", tmp_path / "out", method="joint", echo=lambda s: None)
    doc = json.loads((tmp_path / "out" / "calibration.json").read_text(), parse_constant=pytest.fail)
    assert "3" in doc["excluded_steps"] and any("step 3" in w for w in doc["warnings"])
    assert doc["source"]["method"] == "joint"


def test_imu_tk_xsens_end_to_end(tmp_path):
    """The real IMU-TK Xsens record: scales near the datasheet's (PROVENANCE.md: acc 415, 413, 415 counts
    per m/s^2; gyro 4778, 4758, 4766 counts per rad/s) and a valid calibration file."""
    lines = []
    result = calibrate_from_dir(DATA / "imu_tk-xsens", tmp_path, fmt="imu_tk", gravity=9.81744,
                                echo=lines.append)
    doc = read_calibration(tmp_path / "calibration.json")
    assert doc["source"]["format"] == "imu_tk" and doc["gravity_mps2"] == 9.81744
    np.testing.assert_allclose(1 / np.diag(result.sensors["accel"].H), [415, 413, 415], rtol=0.01)
    np.testing.assert_allclose(1 / np.diag(result.sensors["gyro"].H), [4778, 4758, 4766], rtol=0.01)
    assert any(line.startswith("accel: turntable-free") for line in lines)


def test_partial_nan_rows_named(base):
    session, truth = fresh(base)
    rows = hold_rows(session, 2)
    session.raw["accel"][rows[[10, 20]], 1] = np.nan
    result = calibrate_session(session)
    assert f"accel: 2 row(s) with NaN in some axes only (first row {rows[10]}); not used" in result.warnings
    assert_matches_truth(result.sensors, truth, ("accel",))


def test_imu_tk_files_without_folder(tmp_path):
    (tmp_path / "acc.txt").write_text("0.0 1 2 3\n0.01 1 2 3\n")
    (tmp_path / "gyr.txt").write_text("0.0 1 2 3\n0.01 1 2 4\n0.02 1 1 1\n")
    with pytest.raises(SessionFormatError, match="3 rows against 2"):
        calibrate_from_dir(None, tmp_path / "out", fmt="imu_tk", accel_file=tmp_path / "acc.txt",
                           gyro_file=tmp_path / "gyr.txt", echo=lambda s: None)


def _noiseless_gyro_holds(offsets: np.ndarray) -> HoldStats:
    """Holds of a quantised gyro without noise: integer means, moved by `offsets` (k, 3) counts where a remnant of
    motion (a count flipping a few times) shifts the mean by a fraction of a count."""
    k = len(offsets)
    frac = np.minimum(np.abs(offsets), 1.0)
    return HoldStats(step=np.arange(k), mean=np.array([172.0, -90.0, -31.0]) + offsets,
                     std=np.sqrt(frac * (1 - frac)), count=np.full(k, 450), R=np.tile(np.eye(3), (k, 1, 1)),
                     t_start=np.arange(k) * 10.0, t_end=np.arange(k) * 10.0 + 5)


def test_noiseless_gyro_sub_count_means_are_not_turning():
    """Without noise to dither them, hold means sit up to half a count off: not evidence of turning. A clean
    simulator once lost 15 of 20 holds this way, and the accelerometer with them."""
    rng = np.random.default_rng(3)
    offsets = np.exp(rng.uniform(np.log(1e-3), np.log(0.3), (20, 3))) * rng.choice([-1, 1], (20, 3))
    offsets[:6] = 0.0
    assert _turning_holds(_noiseless_gyro_holds(offsets)) == []
    offsets[16, 1] = 5.0
    assert [j for j, _ in _turning_holds(_noiseless_gyro_holds(offsets))] == [16]


def test_noiseless_session_reports_its_rounding():
    """A simulator without noise: every sensor calibrates without misfit warnings, and each B is within a few
    of its reported standard deviations, which now include the rounding that no averaging removes."""
    session, truth = build_session(seed=5, hold_s=2.5, noise_counts={"accel": 0.0, "gyro": 0.0, "mag": 0.0})
    result = calibrate_session(session)
    assert not [w for w in result.warnings if "misfit" in w], result.warnings
    assert result.excluded_steps == {}
    for name in ("accel", "gyro", "mag"):
        cal = result.sensors[name]
        assert np.all(np.abs(cal.B - truth.B[name]) < 4 * cal.B_std), (name, cal.B - truth.B[name], cal.B_std)


def test_a_hold_visited_again_is_settled_again(base):
    """The hold held again after a resume or a redone step follows its first visit with no move rows between;
    the table came to it anew, so its start is settling too (an interrupted session must not keep what the
    uninterrupted one drops)."""
    session, truth = fresh(base)
    j, idx = session.hold_rows()[5]
    second = idx[len(idx) // 2]
    session.t[second:] += 3.0                                       # the table went away and came back
    again = idx[idx >= second]
    ring = (session.t[again] - session.t[second] < 0.3)[:, None] * np.array([400.0, -300.0, 500.0])
    session.raw["accel"][again] += np.round(ring)
    rows = dict(session.hold_rows(0.5))[j]
    assert (session.t[rows] < session.t[second]).any(), "the first visit is kept"
    assert not ((session.t[rows] >= session.t[second]) & (session.t[rows] < session.t[second] + 0.5)).any()
    assert (session.t[rows] >= session.t[second] + 0.5).any(), "the second visit is kept after its settling"
    assert_matches_truth(calibrate_session(session, settle_s=0.5).sensors, truth, ("accel",))
