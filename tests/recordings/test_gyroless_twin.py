"""`rig discrepancy` on recordings without a gyroscope: the twin replays every sample at the attitude the data give
(the gravity direction, the field direction or both) and compares statistics of the sensors the recording holds.

The CK-Explorer logs (an accelerometer alone; an accelerometer with a magnetometer) must get their twin whatever
their calibration's quality: the tests ask what the twin runs on and says, not how well the model fits. A
magnetometer turned by hand and written from the physics (`mag_synth`), its offset stepping once, must have the
step named blind, where it was and as large as it was to within the estimate's own deviation; the same recording
without the step names nothing."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mag_synth import mag_truth, readings, world_field  # noqa: E402
from test_public_recordings import CK, CK_ACC_IMPORT, CK_ACCMAG_IMPORT  # noqa: E402
from test_unseen_recordings import rig  # noqa: E402

from rig.io.recording import recording_session  # noqa: E402
from rig.io.session_writer import write_session  # noqa: E402

RATE_HZ, DURATION_S = 50.0, 150.0
PER_UT = 1 / 0.15                # counts per uT: an LSB of 0.15 uT
NOISE_UT = 0.3
FLIP_AT, FLIP_UT = 0.55, np.array([2.0, -2.5, 1.5])
SIGMAS = 5.0                     # how far an estimate may lie from the truth, in its own standard deviations


def twin_of(tmp_path: Path, session: Path) -> tuple[dict, dict]:
    done = rig("discrepancy", str(session), "--json", str(tmp_path / "d.json"), "--replicas", "20", timeout=300)
    assert done.returncode == 0, (done.returncode, done.stdout[-800:], done.stderr)
    assert "Traceback" not in done.stderr, done.stderr
    report = json.loads((tmp_path / "d.json").read_text())
    return report, report["twin"]


def families(twin: dict) -> set[str]:
    return {s["family"].split(".")[0] for s in twin["statistics"].values()}


@pytest.mark.parametrize("log, options, sensors", [
    ("acc_log.csv", CK_ACC_IMPORT, {"accel"}),
    ("acc_mag_log.csv", CK_ACCMAG_IMPORT, {"accel", "mag"}),
])
def test_a_recording_without_a_gyroscope_gets_its_twin(tmp_path, log, options, sensors):
    """Every statistic compared is of a sensor the log holds and rig calibrated; nothing is left unanalysed; and
    the extension never leaves fewer statistics inside their band than the plain twin."""
    session = tmp_path / "s"
    done = rig("import", "csv", str(CK / log), *options, "--out", str(session))
    assert done.returncode == 0, done.stderr
    report, twin = twin_of(tmp_path, session)
    calibrated = set(twin["calibration"])
    assert calibrated and calibrated <= sensors, calibrated
    assert not report["not_analysed"] and not twin["not_analysed"], report["not_analysed"]
    assert families(twin) == calibrated, (families(twin), calibrated)
    assert not any(name.startswith("gyro") for name in twin["statistics"]), sorted(twin["statistics"])
    assert twin["model_tests"] == [] and twin["heldout_change"] is None
    assert twin["summary"]["inside_after"] >= twin["summary"]["inside_before"], twin["summary"]
    assert twin["replicas"] - twin["replicas_failed"] >= 10, twin["replicas_failed"]


def hand_turned(seed: int) -> np.ndarray:
    """Fixture -> world attitudes (n, 3, 3) of a hand turning a board slowly through every direction: three Euler
    angles (z, x, z) sweeping several turns each over the recording, at rates of their own, with a wobble."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION_S, 1 / RATE_HZ)
    turns, phase = rng.uniform(2.0, 5.0, 3), rng.uniform(0, 2 * np.pi, 3)
    wobble = 0.2 * np.sin(2 * np.pi * rng.uniform(0.2, 0.5, 3) * t[:, None] + phase)
    angles = 2 * np.pi * turns * t[:, None] / DURATION_S + phase + wobble
    return Rotation.from_euler("zxz", angles).as_matrix()


def magnetometer_alone(folder: Path, seed: int, step_uT: np.ndarray | None) -> Path:
    """A hand-turned magnetometer in counts, its offset stepping by `step_uT` (fixture frame) at FLIP_AT of the
    recording where given."""
    rng = np.random.default_rng(seed)
    R = hand_turned(seed)
    t = np.arange(len(R)) / RATE_HZ
    truth = mag_truth(rng, per_uT=PER_UT)
    y = readings(R, truth, rng, noise_uT=NOISE_UT)
    if step_uT is not None:
        y += np.outer(t >= FLIP_AT * DURATION_S, np.linalg.solve(truth.H, step_uT))
    session = recording_session(t, {"mag": np.round(y)}, units={"mag": "counts"}, source="hand-turned magnetometer",
                                field_uT=truth.field_uT, sample_rate_hz=RATE_HZ)
    return write_session(session, folder)


def instant_tolerance_s(seed: int) -> float:
    """How far from the true instant the step's can be placed before the norm tells: the rows between take the
    step's share along the field, d . s, or not; the misplacement shows once their squares sum to SIGMAS^2 times
    the norm's noise variance. The window about the instant that reaches it, a row more, in seconds."""
    R = hand_turned(seed)
    d = np.einsum("nji,j->ni", R, world_field())
    along = (d / np.linalg.norm(d, axis=1, keepdims=True)) @ FLIP_UT
    i0 = int(np.ceil(FLIP_AT * DURATION_S * RATE_HZ))
    need = (SIGMAS * NOISE_UT) ** 2
    w = next(w for w in range(1, i0) if min(np.sum(along[i0 - w:i0] ** 2), np.sum(along[i0:i0 + w] ** 2)) >= need)
    return (w + 1) / RATE_HZ


def test_a_magnetometers_offset_step_is_found_blind(tmp_path):
    """The step is named, at its instant to within what the norm can tell (`instant_tolerance_s`) and its length
    within SIGMAS of its estimate's deviation; it brings statistics back and pushes none out."""
    report, twin = twin_of(tmp_path, magnetometer_alone(tmp_path / "s", 3, FLIP_UT))
    named = [c for c in twin["causes"] if c["effect"] == "mag_offset_flip"]
    assert [(c["effect"], c["sensor"]) for c in twin["causes"]] == [("mag_offset_flip", "mag")], twin["causes"]
    cause = named[0]
    assert cause["brings_back"] and not cause["pushes_out"], cause
    assert abs(cause["params"]["t_flip"] - FLIP_AT * DURATION_S) <= instant_tolerance_s(3), cause["params"]
    step, sd = np.array(cause["params"]["step_uT"]), np.array(cause["params"]["step_sd_uT"])
    # the calibration's frame is the fixture's up to the soft iron's rotation, which a field alone cannot see: the
    # step's length is compared
    assert abs(np.linalg.norm(step) - np.linalg.norm(FLIP_UT)) <= SIGMAS * np.linalg.norm(sd), (step, sd)
    assert [f["effect"] for f in report["findings"]] == ["mag_offset_flip"], report["findings"]
    assert twin["summary"]["inside_after"] > twin["summary"]["inside_before"], twin["summary"]


def test_a_clean_magnetometer_names_nothing(tmp_path):
    """The same hand and sensor without the step: no cause is named, and nothing is left unanalysed."""
    report, twin = twin_of(tmp_path, magnetometer_alone(tmp_path / "s", 3, None))
    assert twin["causes"] == [] and report["findings"] == [], twin["causes"]
    assert families(twin) == {"mag"} and not report["not_analysed"]
