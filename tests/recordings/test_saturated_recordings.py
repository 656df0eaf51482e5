"""Recordings in which a sensor saturated (clipped at its range), as a user's logger writes them: the calibration
leaves out the poses, turns and motions that read a sample at the rail and says so, or refuses in one line when
what is left cannot determine the sensor. Before, the clipped samples were fitted silently: a gyro clipped at
250 deg/s in hand motions gave H 20 % off with exit 0, an accelerometer axis clipped at 8 m/s^2 a B 0.15 m/s^2
off with only a residual warning.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ferraris_synth import generate  # noqa: E402
from test_unseen_recordings import gyro_not_calibrated, imported, one_clear_line, recording, rig, write_csv  # noqa: E402

from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402
from rig.noise.statistics import pinned_fraction  # noqa: E402

RAIL_250_DPS = float(np.radians(250.0))


def calibrated(tmp_path: Path, rec: dict, name: str):
    folder = imported(tmp_path / name, write_csv(tmp_path / f"{name}.csv", rec))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / name / "cal"), "--no-progress")
    return folder, done


def sensors(tmp_path: Path, name: str) -> dict:
    return json.loads((tmp_path / name / "cal" / "calibration.json").read_text())["sensors"]


def scale_error(H: list, truth: np.ndarray) -> float:
    """How far H is from the truth up to a rotation (the turntable-free fit's frame is the accelerometer's)."""
    return float(np.abs(np.linalg.svd(np.array(H) @ np.linalg.inv(truth), compute_uv=False) - 1).max())


def test_a_pile_at_the_extreme_is_a_rail_a_thin_tail_is_not():
    """Clipping piles samples at the extreme, in SI floats as in counts; quantised noise, whose every value
    repeats, thins out towards its extremes and is never taken for a rail (the old statistic's rule, more than
    the next value, took 1 in 8 such streams for clipped). The calibration and the statistic share the rule."""
    rng = np.random.default_rng(0)
    floats = np.round(rng.normal(0, 3.0, 5000), 6)
    assert pinned_fraction(np.clip(floats, -np.inf, 4.0)) == np.mean(floats >= 4.0)
    assert pinned_fraction(floats) == 0.0
    counts = [np.round(rng.normal(rng.uniform(0, 1), 5.0, 2000)) for _ in range(50)]
    assert [pinned_fraction(x) for x in counts] == [0.0] * 50
    assert pinned_fraction(np.round(rng.normal(0.3, 0.4, 2000))) == 0.0          # a few codes only


def test_a_gyro_clipped_in_some_motions_is_calibrated_from_the_others(tmp_path):
    """A gyro clipped at 250 deg/s in 9 of 15 hand motions: fitted anyway, H came out about 20 % off (exit 0, a
    warning that gravity is not carried); from the 6 unclipped motions it is as good as an unclipped recording's."""
    rec = recording(14, poses=16, move_s=(0.6, 1.0))
    clean = rec["gyro"].copy()
    rec["gyro"] = np.clip(clean, -RAIL_250_DPS, RAIL_250_DPS)
    _, done = calibrated(tmp_path, rec, "clipped")
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr)
    assert "saturated" in done.stdout and "gyro.z (column 'gz') pinned at -4.36332" in done.stdout, done.stdout
    assert "9 of 15 motions between the rests read a sample at a rail and were left out" in done.stdout, done.stdout
    clipped = scale_error(sensors(tmp_path, "clipped")["gyro"]["H"], rec["Hg"])
    rec["gyro"] = clean
    _, done = calibrated(tmp_path, rec, "clean")
    unclipped = scale_error(sensors(tmp_path, "clean")["gyro"]["H"], rec["Hg"])
    assert clipped < max(3 * unclipped, 2e-3), (clipped, unclipped)


def test_an_accelerometer_axis_clipped_in_some_poses_leaves_them_out(tmp_path):
    """An accelerometer whose z clips at 8 m/s^2: the 4 poses with gravity near z read 8 where gravity gives more,
    and the norm fit took them for scale (B 0.15 m/s^2 off, a residual warning only). Left out, the other poses
    give B and H within their noise of the truth."""
    rec = recording(14, poses=18)
    rec["accel"][:, 2] = np.clip(rec["accel"][:, 2], -8.0, 8.0)
    _, done = calibrated(tmp_path, rec, "clipped")
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr)
    assert "accel.z (column 'az') pinned at 8" in done.stdout and "saturated" in done.stdout, done.stdout
    assert "static intervals read a sample at a rail and were left out" in done.stdout, done.stdout
    accel = sensors(tmp_path, "clipped")["accel"]
    assert scale_error(accel["H"], rec["Ha"]) < 1e-3
    assert np.abs(np.array(accel["B"]) - rec["Ba"]).max() < 0.01, "m/s^2; the pose means' noise is 0.001"


def test_a_recording_whose_every_motion_saturates_gets_no_gyro_and_says_why(tmp_path):
    """Every hand motion beyond a 0.5 rad/s range: nothing carries gravity between the rests with the rate intact,
    so there is no gyro H to write; the accelerometer is, and one line names the recording and the saturation,
    exit 1."""
    rec = recording(14, poses=16, move_s=(0.6, 1.0))
    rec["gyro"] = np.clip(rec["gyro"], -0.5, 0.5)
    folder, done = calibrated(tmp_path, rec, "all")
    why = gyro_not_calibrated(done, tmp_path / "all" / "cal")
    assert str(folder) in why and "saturated" in why and "pinned at 0.5" in why, why


def test_with_segments_a_clipped_turn_is_left_out_and_clipped_faces_are_named():
    """A Ferraris session (six faces, three turns): the gyro z clipped in the z turn doubled H's error silently;
    left out, the other turns and the motions give it as well as the clean session. Faces clipped on x leave four,
    too few for the face fit: refused naming the saturation, not the count of faces the user did record."""
    session, truth = generate(0)
    clean = calibrate_recording(session).sensors["gyro"].H
    session.raw["gyro"][:, 2] = np.clip(session.raw["gyro"][:, 2], -2500, 2500)
    rec = calibrate_recording(session)
    rel = lambda H: float(np.linalg.norm(H - truth.gyro_H) / np.linalg.norm(truth.gyro_H))  # noqa: E731
    assert len(rec.turns) == 2 and rel(rec.sensors["gyro"].H) < 1.3 * rel(clean), (rel(rec.sensors["gyro"].H),
                                                                                     rel(clean))
    assert any("gyro.z pinned at 2500" in w and "1 of 3 turns" in w for w in rec.warnings), rec.warnings

    session, _ = generate(0)
    session.raw["accel"][:, 0] = np.clip(session.raw["accel"][:, 0], -1900, 1900)
    try:
        calibrate_recording(session)
    except CalibrationError as exc:
        assert "2 poses with accel.x pinned at -1900" in str(exc) and "saturated" in str(exc), exc
    else:
        raise AssertionError("faces clipped on x were calibrated")


def test_both_ends_of_a_twos_complement_code_are_rails_once_one_of_them_piles_up():
    """An MPU-6050 logged in counts (tomisuarez2/ImuCalibration's session): its gyro x piled 10 samples at -32768
    and touched +32767 twice in another motion, too few for a pile; that motion was fitted as if whole. A pile at
    -2^15 says the code is 16 bits: +32767 is its other end, on every axis of the sensor."""
    from rig.calibration.numerics.saturation import pinned_rows

    rng = np.random.default_rng(3)
    y = np.round(rng.normal(0, 4000.0, (3000, 3)))
    y[100:110, 0] = -32768.0                                  # a pile: clipped
    y[500:502, 0] = 32767.0                                   # two samples at the other end
    y[900, 2] = 32767.0                                       # one on another axis
    y[1200, 1] = 30000.0                                      # an extreme that is no end of the code
    found, hit = pinned_rows(y)
    assert {(r.axis, r.value) for r in found} == {(0, -32768.0), (0, 32767.0), (2, 32767.0)}
    assert hit[[100, 500, 501, 900]].all() and not hit[1200]
    alone = np.round(rng.normal(0, 4000.0, (3000, 3)))
    alone[7, 1] = 32767.0                                     # without a pile, one sample proves nothing
    assert pinned_rows(alone)[0] == []
