"""Recordings unlike the two real ones, as a user brings them from their own logger: a plain CSV, imported with
`rig import csv` and run through `rig calibrate --from`, `rig discrepancy` and `rig noise` as processes.

The recordings are made here: a unit at rest in hand-placed poses (random attitudes) with smooth hand motions
between them, gravity 9.81, white noise, biases and an H near identity. Each test breaks one thing a real logger
breaks (a stuck axis, a paused log, a half-empty row, ...) and requires one clear line, a truthful exit code and
no traceback, or a result that is physically right.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

RIG = [sys.executable, "-m", "rig.cli"]
G = 9.81
SI = ["--units", "accel=m/s^2,gyro=rad/s"]
COLUMNS = ["--time", "time", "--accel", "ax,ay,az", "--gyro", "gx,gy,gz"]


def recording(seed: int, *, rate: float = 50.0, poses: int = 14, rest_s: float = 50.0, pose_s=(3.0, 5.0),
              move_s=(1.5, 2.5)) -> dict:
    """t, accel (m/s^2), gyro (rad/s) and the pose of every row (-1 in a motion) of a hand-placed session."""
    rng = np.random.default_rng(seed)
    attitudes = [Rotation.random(random_state=int(rng.integers(1 << 30))) for _ in range(poses)]
    spans = [(rest_s, 0, None)]
    for k in range(1, poses):
        spans += [(rng.uniform(*move_s), None, k), (rng.uniform(*pose_s), k, None)]
    t = np.arange(int(sum(s[0] for s in spans) * rate)) / rate
    quat, rate_body, pose = np.zeros((len(t), 4)), np.zeros((len(t), 3)), np.full(len(t), -1)
    start = 0.0
    for duration, still, moving_to in spans:
        rows = (t >= start) & (t < start + duration)
        if still is not None:
            quat[rows], pose[rows] = attitudes[still].as_quat(), still
        else:
            turn = (attitudes[moving_to - 1].inv() * attitudes[moving_to]).as_rotvec()
            tau = (t[rows] - start) / duration
            s = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5                   # smooth start and stop
            quat[rows] = (attitudes[moving_to - 1] * Rotation.from_rotvec(np.outer(s, turn))).as_quat()
            rate_body[rows] = np.outer(30 * tau ** 2 * (1 - tau) ** 2 / duration, turn)
        start += duration
    force = Rotation.from_quat(quat).inv().apply([0.0, 0.0, G])
    Ha, Hg = np.eye(3) + rng.normal(0, 0.01, (3, 3)), np.eye(3) + rng.normal(0, 0.01, (3, 3))
    Ba = rng.normal(0, 0.1, 3)
    accel = np.linalg.solve(Ha, force.T).T + Ba + rng.normal(0, 0.01, (len(t), 3))
    gyro = np.linalg.solve(Hg, rate_body.T).T + rng.normal(0, 0.01, 3) + rng.normal(0, 0.003, (len(t), 3))
    return {"t": t, "accel": accel, "gyro": gyro, "pose": pose, "Hg": Hg, "Ha": Ha, "Ba": Ba, "quat": quat}


def write_csv(path: Path, rec: dict, rows: np.ndarray | None = None) -> Path:
    data = np.column_stack([rec["t"], rec["accel"], rec["gyro"]])
    if rows is not None:
        data = data[rows]
    with open(path, "w") as f:
        f.write("time,ax,ay,az,gx,gy,gz\n")
        np.savetxt(f, data, fmt=["%.4f"] + ["%.6f"] * 6, delimiter=",")
    return path


def rig(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([*RIG, *args], capture_output=True, text=True, timeout=timeout)


def one_clear_line(done: subprocess.CompletedProcess) -> str:
    err = done.stderr.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


def gyro_not_calibrated(done: subprocess.CompletedProcess, out: Path) -> str:
    """`rig calibrate --from` that wrote the accelerometer and refused the gyro: exit 1 (a check did not pass), the
    reason on one line of its own, and a calibration.json without a gyro that says why; the reason is returned."""
    assert done.returncode == 1, (done.returncode, done.stdout[-800:], done.stderr)
    assert "Traceback" not in done.stderr + done.stdout
    lines = [line for line in done.stdout.splitlines() if line.startswith("gyro: not calibrated: ")]
    assert len(lines) == 1, done.stdout
    cal = json.loads((out / "calibration.json").read_text())
    assert "accel" in cal["sensors"] and "gyro" not in cal["sensors"], cal["sensors"].keys()
    assert cal["not_calibrated"]["gyro"] in lines[0]
    return lines[0]


def imported(tmp_path: Path, csv: Path, *extra: str) -> Path:
    done = rig("import", "csv", str(csv), *COLUMNS, *SI, "--gravity", str(G), "--out", str(tmp_path / "s"), *extra)
    assert done.returncode == 0, done.stderr
    return tmp_path / "s"


def test_rig_noise_names_a_stuck_axis_of_a_static_log(tmp_path):
    """Ten minutes of a still unit whose gyro z never changes (a stuck or disconnected axis): its Allan deviation is
    zero at every tau; `rig noise` crashed indexing the empty curve (exit 70). It must name the axis, exit 2."""
    rec = recording(1, poses=1, rest_s=600.0)
    rec["gyro"][:, 2] = 0.002
    folder = imported(tmp_path, write_csv(tmp_path / "still.csv", rec))
    done = rig("noise", str(folder))
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "gyro.z: the same value" in one_clear_line(done) and "a stuck axis" in done.stderr


def test_a_stuck_axis_is_named_not_calibrated(tmp_path):
    """Fourteen poses whose gyro y never changes: `rig calibrate --from` wrote a gyro H whose y column stayed at its
    start (1.8 on the diagonal, 'standard deviation' 0) and exited 0; with the accelerometer's x stuck it blamed the
    gyro (det(H) = 0) and `rig discrepancy` went on to name effects in it (exit 0). Both must name the column."""
    rec = recording(2)
    rec["gyro"][:, 1] = 0.0123
    folder = imported(tmp_path, write_csv(tmp_path / "stuck.csv", rec))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    assert done.returncode == 3, (done.returncode, done.stdout, done.stderr)
    assert "gyro.y (column 'gy') holds the same value" in one_clear_line(done)
    assert not (tmp_path / "cal" / "calibration.json").exists()

    rec = recording(3)
    rec["accel"][:, 0] = 0.37
    folder = imported(tmp_path / "a", write_csv(tmp_path / "stuck_accel.csv", rec))
    done = rig("discrepancy", str(folder), "--json", str(tmp_path / "d.json"), "--replicas", "10")
    assert done.returncode == 3, (done.returncode, done.stdout, done.stderr)
    err = one_clear_line(done)
    assert "accel.x (column 'ax') holds the same value" in err and err.count(str(folder)) == 1, err


def test_a_log_paused_between_poses_is_not_given_a_gyro_calibration(tmp_path):
    """A logger that records only while the unit rests (the motions between poses are not in the file): the
    turntable-free gyro fit integrated across the gaps and wrote an H hundreds of times too large, exit 0. With no
    motion recorded whole there is nothing to fit H to: the accelerometer is written, the gyro refused on a line
    naming the recording, exit 1. With some motions cut, the gyro is fitted to the whole ones and comes out right."""
    rec = recording(4, poses=16)
    folder = imported(tmp_path, write_csv(tmp_path / "paused.csv", rec, rows=rec["pose"] >= 0))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    why = gyro_not_calibrated(done, tmp_path / "cal")
    assert str(folder) in why and "recorded whole" in why, why

    left = np.maximum.accumulate(np.where(rec["pose"] >= 0, rec["pose"], -1))     # the pose a motion row leaves
    cut = (rec["pose"] < 0) & np.isin(left, [3, 8])                                 # two motions not logged
    folder = imported(tmp_path / "b", write_csv(tmp_path / "two_cut.csv", rec, rows=~cut))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal2"), "--no-progress")
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr)
    assert "2 of 15 motions between the rests have a gap" in done.stdout, done.stdout
    H = np.array(json.loads((tmp_path / "cal2" / "calibration.json").read_text())["sensors"]["gyro"]["H"])
    # the accelerometer's frame is the calibrated one (imu_tk's convention): compare the gyro's scale, not its axes
    assert np.allclose(np.linalg.svd(H @ np.linalg.inv(rec["Hg"]), compute_uv=False), 1.0, atol=0.01)


def test_a_half_empty_sample_is_refused_at_the_line_of_the_users_file(tmp_path):
    """One gyro cell left empty (a logger that dropped a field): `rig import csv` wrote a session that every command
    then refused, naming a line of a samples.csv the user never wrote. The import must name the user's file, line
    and column, exit 2; a magnetometer present on every other row only (all three cells empty) still imports."""
    rec = recording(5, poses=3, rest_s=5.0)
    csv = write_csv(tmp_path / "holes.csv", rec)
    lines = csv.read_text().splitlines()
    cells = lines[40].split(",")
    cells[4] = ""                                                   # gx of the 40th sample, file line 41
    lines[40] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    done = rig("import", "csv", str(csv), *COLUMNS, *SI, "--out", str(tmp_path / "s"))
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    err = one_clear_line(done)
    assert f"{csv}, line 41, column 'gx'" in err, err
    assert not (tmp_path / "s" / "samples.csv").exists()

    data = np.column_stack([rec["t"], rec["accel"], rec["gyro"], rec["accel"] * 5.0])
    text = ["time,ax,ay,az,gx,gy,gz,mx,my,mz"]
    for k, row in enumerate(data):
        cells = [f"{v:.6f}" for v in row]
        text.append(",".join(cells[:7] + (["", "", ""] if k % 2 else cells[7:])))
    (tmp_path / "mag.csv").write_text("\n".join(text) + "\n")
    done = rig("import", "csv", str(tmp_path / "mag.csv"), *COLUMNS, "--mag", "mx,my,mz", "--field-uT", "48",
               "--units", "accel=m/s^2,gyro=rad/s,mag=uT", "--out", str(tmp_path / "m"))
    assert done.returncode == 0, done.stderr
    done = rig("noise", str(tmp_path / "m"))                       # reads the session back (not still: exit 2)
    assert done.returncode == 2 and "is not still" in one_clear_line(done), done.stderr


def test_a_rest_shorter_than_imu_tks_is_found_and_a_rest_said_wrongly_is_named_as_the_reason(tmp_path):
    """Sixteen poses after an 8 s rest (imu_tk's method wants 50 s): taken over a span that moves, the threshold
    merged every pose into one, and the refusal asked for more poses than the sixteen recorded. The rest is found
    in the data now; where the recording says 50 s anyway, the refusal names the rest and what the data show (one
    line, no result)."""
    rec = recording(6, poses=16, rest_s=8.0)
    folder = imported(tmp_path / "found", write_csv(tmp_path / "short_rest.csv", rec))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr)
    cal = json.loads((tmp_path / "cal" / "calibration.json").read_text())["sensors"]
    assert 7.0 < cal["accel"]["initial_rest_s"] <= 8.0 and len(cal["accel"]["intervals"]) == 16, cal["accel"]
    H = np.array(cal["gyro"]["H"])
    assert np.abs(np.linalg.svd(H @ np.linalg.inv(rec["Hg"]), compute_uv=False) - 1).max() < 0.01
    said = imported(tmp_path / "said", tmp_path / "short_rest.csv", "--initial-rest-s", "50")
    done = rig("calibrate", "--from", str(said), "--out", str(tmp_path / "cal2"), "--no-progress")
    assert done.returncode == 3, (done.returncode, done.stdout, done.stderr)
    line = one_clear_line(done)
    assert "the first 50 s are not at rest" in line and "the data show an initial rest of 7." in line, line