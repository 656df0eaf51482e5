"""A magnetometer logged by itself and tumbled by hand (the hard- and soft-iron calibration everyone does): B and a
symmetric H from every sample, in the magnetometer's own frame, within their stated deviations of the truth the
generator knows; refused, saying how much of the sphere the samples cover, only where they leave the ellipsoid
undetermined. The field is `mag_synth`'s (48 uT dipping 60 deg, hard iron up to 40 uT, soft iron a few %,
0.3 uT of noise), the motion `tumble_synth`'s (a minute at 50 Hz: 3000 samples)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mag_synth import mag_truth, readings  # noqa: E402
from test_unseen_recordings import one_clear_line, rig  # noqa: E402
from tumble_synth import level_turns, tumble  # noqa: E402

from rig.calibration.recordings.mag_alone import calibrate_mag_alone  # noqa: E402
from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402
from rig.io.recording import recording_session  # noqa: E402

Z_MAX = 4.5


def symmetric_truth(H: np.ndarray) -> np.ndarray:
    """The symmetric positive-definite map with the same ellipsoid as H: (H^T H)^(1/2). A magnetometer alone
    cannot see the rotation that H has beyond it."""
    w, V = np.linalg.eigh(H.T @ H)
    return (V * np.sqrt(w)) @ V.T


def tumbled(seed: int, **kw):
    rng = np.random.default_rng(seed)
    t, R = tumble(rng, **kw)
    truth = mag_truth(rng)
    return t, truth, readings(R, truth, rng)


def z_scores(cal, B_truth: np.ndarray, H_truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (cal.B - B_truth) / cal.B_std, (cal.H - H_truth) / cal.H_std


def test_a_tumbled_magnetometer_alone_comes_out_within_its_stated_deviations():
    """24 hand tumbles: every entry within 4.5 of its deviations, and the errors of B and of H's diagonal and
    off-diagonal entries in their deviations with an RMS near 1 (measured over 100 seeds: 1.02, 1.03, 1.09)."""
    zB, diagonal, off = [], [], []
    for seed in range(24):
        t, truth, y = tumbled(seed)
        cal, warnings = calibrate_mag_alone(y, truth.field_uT, source=f"<tumble {seed}>", raw_unit="uT")
        assert warnings == [] and cal.extra["frame"] == "mag"
        assert np.allclose(cal.H, cal.H.T, rtol=0, atol=1e-12 * np.abs(cal.H).max()), "symmetric: its own frame"
        b, h = z_scores(cal, truth.B, symmetric_truth(truth.H))
        assert np.abs(b).max() < Z_MAX and np.abs(h).max() < Z_MAX, (seed, b.round(1), h.round(1))
        zB += list(b)
        diagonal += list(np.diag(h))
        off += list(h[np.triu_indices(3, 1)])
    rms = [float(np.sqrt(np.mean(np.square(v)))) for v in (zB, diagonal, off)]
    assert all(0.75 < r < 1.3 for r in rms), rms


def test_without_the_local_field_it_is_calibrated_to_the_magnitude_its_samples_show():
    """No field_uT: H with det(H) = 1, the true shape scaled alike, and the field magnitude that makes within its
    stated deviation of the truth's; said in a warning and in the calibration."""
    zH, zN = [], []
    for seed in range(8):
        t, truth, y = tumbled(seed)
        cal, warnings = calibrate_mag_alone(y, None, source="<no field>", raw_unit="uT")
        P = symmetric_truth(truth.H)
        scale = np.linalg.det(P) ** (-1.0 / 3.0)
        zH += list(((cal.H - P * scale) / cal.H_std).ravel())
        zN.append((cal.extra["field_magnitude"] - truth.field_uT * scale) / cal.extra["field_magnitude_std"])
        assert cal.extra["field_uT_source"] == "data" and cal.extra["field_magnitude_unit"] == "uT"
        assert len(warnings) == 1 and "no field_uT" in warnings[0] and "--field-uT" in warnings[0]
        assert np.linalg.det(cal.H) == pytest.approx(1.0, abs=1e-9)
    assert np.abs(zH).max() < Z_MAX and np.abs(zN).max() < Z_MAX, (np.abs(zH).max(), zN)
    assert 0.6 < np.sqrt(np.mean(np.square(zH))) < 1.4


def test_a_magnet_passing_by_is_left_out_and_said():
    """Two seconds whose field is 40 % stronger (a magnet brought near): its samples would pull B and H; they lie
    far off the ellipsoid the others fix, and are left out with a warning."""
    t, truth, y = tumbled(5)
    near = (t > 20.0) & (t < 22.0)
    y[near] = truth.B + (y[near] - truth.B) * 1.4
    cal, warnings = calibrate_mag_alone(y, truth.field_uT, source="<magnet>", raw_unit="uT")
    assert len(warnings) == 1 and "left out" in warnings[0] and f"{near.sum()} of {len(y)}" in warnings[0], warnings
    b, h = z_scores(cal, truth.B, symmetric_truth(truth.H))
    assert np.abs(b).max() < Z_MAX and np.abs(h).max() < Z_MAX


@pytest.mark.parametrize("tilt_deg", [0.0, 5.0])
def test_samples_that_sweep_too_little_of_the_sphere_are_refused_saying_how_much(tilt_deg):
    """A unit turned round on a table (and tilted a little): its field sweeps a band of the sphere, which leaves the
    axis across it undetermined. Refused in one line saying how much of the sphere the samples cover and where
    they never point."""
    rng = np.random.default_rng(3)
    t, R = level_turns(rng, tilt_deg=tilt_deg)
    truth = mag_truth(rng)
    with pytest.raises(CalibrationError) as info:
        calibrate_mag_alone(readings(R, truth, rng), truth.field_uT, source="<level>", raw_unit="uT")
    message = str(info.value)
    assert message.startswith("<level>: mag: ") and "\n" not in message
    assert "% of the sphere" in message and "none comes within" in message, message


def test_a_band_wide_enough_is_calibrated_within_its_deviations():
    """Tilted by up to 30 deg as it turns: a band of about a quarter of the sphere, which does fix the nine
    parameters (less well than a tumble): calibrated, the errors within the deviations stated."""
    for seed in range(3):
        rng = np.random.default_rng(seed)
        t, R = level_turns(rng, tilt_deg=30.0)
        truth = mag_truth(rng)
        cal, _ = calibrate_mag_alone(readings(R, truth, rng), truth.field_uT, source="<band>", raw_unit="uT")
        assert cal.extra["sphere_coverage"] < 0.5
        b, h = z_scores(cal, truth.B, symmetric_truth(truth.H))
        assert np.abs(b).max() < Z_MAX and np.abs(h).max() < Z_MAX, (seed, b.round(1), h.round(1))


def test_a_recording_with_segments_calibrates_its_magnetometer_from_every_sample():
    """Static segments say nothing a magnetometer alone can use: every sample is, still or not."""
    t, truth, y = tumbled(7)
    segments = [{"name": "rest", "t0": 0.0, "t1": 1.0, "kind": "static"}]
    session = recording_session(t, {"mag": y}, units={"mag": "uT"}, source="<segments>", field_uT=truth.field_uT,
                                segments=segments, sample_rate_hz=50.0)
    cal = calibrate_recording(session).sensors["mag"]
    assert cal.extra["samples"] == len(t) and cal.extra["frame"] == "mag"
    b, h = z_scores(cal, truth.B, symmetric_truth(truth.H))
    assert np.abs(b).max() < Z_MAX and np.abs(h).max() < Z_MAX


def write_mag_csv(path: Path, t: np.ndarray, y: np.ndarray, fmt: str = "%.4f") -> Path:
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header="t,mx,my,mz", comments="",
               fmt=["%.3f"] + [fmt] * 3)
    return path


def test_rig_calibrate_from_an_imported_magnetometer_log(tmp_path):
    """`rig import csv` of a magnetometer alone, without --field-uT, then `rig calibrate --from`: exit 0, the
    magnetometer in its own frame, calibrated to its own field and saying so, within its stated deviations."""
    t, truth, y = tumbled(11)
    done = rig("import", "csv", str(write_mag_csv(tmp_path / "mag.csv", t, y)), "--time", "t", "--mag", "mx,my,mz",
               "--units", "mag=uT", "--out", str(tmp_path / "s"))
    assert done.returncode == 0, done.stderr
    assert "rig calibrate --from, rig discrepancy (no gyroscope: each sample replayed at the attitude the field's " \
           "direction gives), rig noise take it" in done.stdout, done.stdout
    done = rig("calibrate", "--from", str(tmp_path / "s"), "--out", str(tmp_path / "c"))
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert "warning: mag: no field_uT in the recording" in done.stdout, done.stdout
    doc = json.loads((tmp_path / "c" / "calibration.json").read_text())
    mag = doc["sensors"]["mag"]
    assert (mag["frame"], mag["field_uT_source"], mag["unit"]) == ("mag", "data", "uT")
    P = symmetric_truth(truth.H)
    P = P / np.linalg.det(P) ** (1.0 / 3.0)
    zB = (np.array(mag["B"]) - truth.B) / np.array(mag["B_std"])
    zH = (np.array(mag["H"]) - P) / np.array(mag["H_std"])
    assert np.abs(zB).max() < Z_MAX and np.abs(zH).max() < Z_MAX, (zB.round(1), zH.round(1))


def test_a_magnetometer_in_counts_without_the_field_says_its_output_is_in_counts(tmp_path):
    """Raw counts (0.15 uT a count) and no --field-uT: the sphere's radius is known in counts only, so the
    calibrated output is in counts, and calibration.json says so rather than calling it uT; with --field-uT the
    same log is calibrated in uT."""
    rng = np.random.default_rng(12)
    t, R = tumble(rng)
    truth = mag_truth(rng, per_uT=1 / 0.15)
    counts = np.round(readings(R, truth, rng, noise_uT=0.3))
    csv = write_mag_csv(tmp_path / "mag.csv", t, counts, fmt="%.0f")
    for field, unit in ((None, "counts"), ("48", "uT")):
        out = tmp_path / (unit + "_s")
        done = rig("import", "csv", str(csv), "--time", "t", "--mag", "mx,my,mz", "--out", str(out),
                   *(("--field-uT", field) if field else ()))
        assert done.returncode == 0, done.stderr
        done = rig("calibrate", "--from", str(out), "--out", str(tmp_path / unit))
        assert done.returncode == 0, done.stderr
        mag = json.loads((tmp_path / unit / "calibration.json").read_text())["sensors"]["mag"]
        assert mag["unit"] == unit and mag["field_uT_source"] == ("given" if field else "data")
        P = symmetric_truth(truth.H)                                  # uT per count
        if not field:
            radius = truth.field_uT / np.linalg.det(P) ** (1.0 / 3.0)   # the field's magnitude in counts
            assert abs(mag["field_magnitude"] - radius) < Z_MAX * mag["field_magnitude_std"]
            P = P * radius / truth.field_uT                            # counts per count, det 1
        zH = (np.array(mag["H"]) - P) / np.array(mag["H_std"])
        assert np.abs(zH).max() < Z_MAX, (unit, zH.round(1))


def test_a_gyro_beside_a_magnetometer_is_not_calibrated_and_says_why(tmp_path):
    """A gyro and a magnetometer, no accelerometer: the magnetometer is calibrated; the gyro cannot be (its motions
    are tied to gravity), which is said on its own line and in calibration.json, exit 1."""
    t, truth, y = tumbled(13)
    gyro = np.random.default_rng(0).normal(0.0, 0.01, y.shape)
    np.savetxt(tmp_path / "log.csv", np.column_stack([t, gyro, y]), delimiter=",", header="t,gx,gy,gz,mx,my,mz",
               comments="", fmt="%.5f")
    done = rig("import", "csv", str(tmp_path / "log.csv"), "--time", "t", "--gyro", "gx,gy,gz", "--mag", "mx,my,mz",
               "--units", "gyro=rad/s,mag=uT", "--field-uT", "48", "--out", str(tmp_path / "s"))
    assert done.returncode == 0, done.stderr
    done = rig("calibrate", "--from", str(tmp_path / "s"), "--out", str(tmp_path / "c"))
    assert done.returncode == 1 and "Traceback" not in done.stderr, (done.returncode, done.stderr)
    assert any(line.startswith("gyro: not calibrated: ") and "no accelerometer" in line
               for line in done.stdout.splitlines()), done.stdout
    doc = json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert list(doc["sensors"]) == ["mag"] and "accelerometer" in doc["not_calibrated"]["gyro"]


def test_rig_calibrate_refuses_a_log_turned_about_one_axis_with_exit_3_saying_its_coverage(tmp_path):
    """A magnetometer turned round on a table and barely tilted, through `rig import csv` and `rig calibrate
    --from`: the data cannot fix the ellipsoid (exit 3, a fault of the data), said in one line with how much of the
    sphere they cover; no calibration.json."""
    rng = np.random.default_rng(4)
    t, R = level_turns(rng, tilt_deg=3.0)
    truth = mag_truth(rng)
    csv = write_mag_csv(tmp_path / "mag.csv", t, readings(R, truth, rng))
    done = rig("import", "csv", str(csv), "--time", "t", "--mag", "mx,my,mz", "--units", "mag=uT", "--field-uT", "48",
               "--out", str(tmp_path / "s"))
    assert done.returncode == 0, done.stderr
    done = rig("calibrate", "--from", str(tmp_path / "s"), "--out", str(tmp_path / "c"))
    assert done.returncode == 3, (done.returncode, done.stdout, done.stderr)
    line = one_clear_line(done)
    assert "mag: " in line and "% of the sphere" in line and "turn the sensor" in line, line
    assert not (tmp_path / "c" / "calibration.json").exists()
