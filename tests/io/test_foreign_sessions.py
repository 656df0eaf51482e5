"""Turntable sessions in the interchange layout written by another tool (a lab's own logger, another rig), read by
`rig calibrate --from`: each test is a case that was wrong (a silent wrong result, or a refusal that named the
wrong cause) when such files were generated from session-csv.md alone and varied as other tools vary them.

The files are written here by hand, line by line, as another program would: nothing of `rig.io` writes them.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

RIG = [sys.executable, "-m", "rig.cli"]
G, FIELD_UT, DIP = 9.80665, 48.0, np.radians(62.0)
SCALE = {"accel": 16384 / G, "gyro": 16.4 * 180 / np.pi, "mag": 6.6}     # counts per m/s^2, rad/s, uT
NAMES = {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]}


def _rx(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _rz(b):
    c, s, o, z = np.cos(b), np.sin(b), np.ones_like(b), np.zeros_like(b)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _quat(a, b):
    """q of Rx(a) Rz(b): qx(a) * qz(b) (Hamilton), scalar first, w >= 0."""
    ca, sa, cb, sb = np.cos(a / 2), np.sin(a / 2), np.cos(b / 2), np.sin(b / 2)
    q = np.stack([ca * cb, sa * cb, -sa * sb, ca * sb], -1)
    return np.where(q[:, :1] < 0, -q, q)


def write_foreign_session(folder: Path, *, rate=100.0, hold_s=3.0, n=12, sensors=("accel", "gyro", "mag"),
                          t_scale=1.0, clip=None, stuck=None, seed=0, sample_rate_hz=True, pad=False) -> dict:
    """A two-axis table (R = Rx(outer) Rz(inner)) at n orientations with cosine moves between them, the unit's
    counts y = K u + B + noise; returns the truth {sensor: (H, B)} with u = H (y - B). clip: (sensor, axis, limit)
    clips that axis at +-limit counts; stuck: (sensor, axis) holds that axis at its first value; t_scale writes t
    in another unit (1000: ms); pad writes ", " between cells."""
    rng = np.random.default_rng(seed)
    K = {s: SCALE[s] * (np.eye(3) + 0.01 * rng.standard_normal((3, 3))) for s in sensors}
    B = {s: rng.uniform(-200, 200, 3) if s != "gyro" else rng.uniform(-30, 30, 3) for s in sensors}
    outer = np.array([0, 90, 180, 270, 45, 135, 225, 315, 30, 120, 210, 300] * 2, float)[:n]
    inner = (np.arange(n) * 67.0 + 5) % 360.0
    sched = np.column_stack([outer, inner])
    t, ang, rate_dps, phase, step, now = [], [], [], [], [], 0.0
    for j in range(n):
        k = int(round(hold_s * rate))
        t.append(now + np.arange(k) / rate); ang.append(np.repeat(sched[j:j + 1], k, 0))
        rate_dps.append(np.zeros((k, 2))); phase += ["hold"] * k; step += [j] * k
        now += k / rate
        if j + 1 < n:
            d = (sched[j + 1] - sched[j] + 180) % 360 - 180
            T = max(1.0, 1.5 * np.abs(d).max() / 60.0)
            m = int(round(T * rate))
            tau = (np.arange(m) + 1) / (m + 1)
            t.append(now + np.arange(m) / rate); ang.append(sched[j] + (0.5 - 0.5 * np.cos(np.pi * tau))[:, None] * d)
            rate_dps.append((0.5 * np.pi * np.sin(np.pi * tau) * rate / (m + 1))[:, None] * d)
            phase += ["move"] * m; step += [j] * m
            now += m / rate
    t, ang, rate_dps = np.concatenate(t), np.concatenate(ang), np.concatenate(rate_dps)
    a, b = np.radians(ang[:, 0]), np.radians(ang[:, 1])
    R = _rx(a) @ _rz(b)
    omega = (np.einsum("nji,j->ni", _rz(b), [1.0, 0, 0]) * np.radians(rate_dps[:, :1])
             + np.array([0, 0, 1.0]) * np.radians(rate_dps[:, 1:]))
    u = {"accel": np.einsum("nji,j->ni", R, [0, 0, G]), "gyro": omega,
         "mag": np.einsum("nji,j->ni", R, FIELD_UT * np.array([np.cos(DIP), 0, -np.sin(DIP)]))}
    noise = {"accel": 3.0, "gyro": 2.0, "mag": 2.0}
    cols = {"t": [f"{x * t_scale:.6f}" for x in t], "phase": phase, "step": [str(s) for s in step]}
    for k, c in enumerate(_quat(a, b).T):
        cols["q" + "wxyz"[k]] = [f"{x:.7f}" for x in c]
    for s in sensors:
        y = np.round(u[s] @ K[s].T + B[s] + noise[s] * rng.standard_normal(u[s].shape))
        if clip and clip[0] == s:
            y[:, clip[1]] = np.clip(y[:, clip[1]], -clip[2], clip[2])
        if stuck and stuck[0] == s:
            y[:, stuck[1]] = y[0, stuck[1]]
        for k, name in enumerate(NAMES[s]):
            cols[name] = ["" if (s == "mag" and i % 2) else str(int(v)) for i, v in enumerate(y[:, k])]
    sep = ", " if pad else ","
    lines = [",".join(cols)] + [sep.join(row) for row in zip(*cols.values())]
    folder.mkdir(parents=True)
    (folder / "samples.csv").write_text("\n".join(lines) + "\n")
    meta = {"format": "imu-session-csv/1", "gravity_mps2": G, "sensors": {s: NAMES[s] for s in sensors},
            "logger": "another lab's tool"}
    if sample_rate_hz:
        meta["sample_rate_hz"] = rate
    if "mag" in sensors:
        meta["field_uT"] = FIELD_UT
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))
    return {s: (np.linalg.inv(K[s]), B[s]) for s in sensors}


def calibrate(folder: Path, out: Path, *args):
    res = subprocess.run([*RIG, "calibrate", "--from", str(folder), "--out", str(out), "--no-progress", *args],
                         capture_output=True, text=True, timeout=300)
    assert "Traceback" not in res.stdout + res.stderr, res.stderr
    cal = json.loads((out / "calibration.json").read_text()) if (out / "calibration.json").exists() else None
    return res, cal


def h_error(cal: dict, truth: dict, sensor: str) -> float:
    H, Ht = np.array(cal["sensors"][sensor]["H"]), truth[sensor][0]
    return float(np.abs(H - Ht).max() / np.abs(Ht).max())


def test_a_logger_at_1_hz_keeps_its_holds(tmp_path):
    """Rows 1 s apart were each a hold visit of their own (the visit gap was 0.5 s), all emptied by the settling
    time: "accel: 0 usable orientations, need at least 6" about a file with 12 of them, exit 3."""
    truth = write_foreign_session(tmp_path / "s", rate=1.0, hold_s=20.0, sensors=("accel", "mag"))
    res, cal = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    assert h_error(cal, truth, "accel") < 1e-3 and h_error(cal, truth, "mag") < 5e-3


def test_a_stuck_gyro_axis_is_refused_by_its_column(tmp_path):
    """A gyro axis stuck at one value calibrated to an H 24 times too large with exit 0 (a warning about the
    moves' misfit was all); a stuck accelerometer axis was refused as "coplanar orientations"."""
    write_foreign_session(tmp_path / "g", stuck=("gyro", 2))
    res, cal = calibrate(tmp_path / "g", tmp_path / "out_g")
    assert res.returncode == 3 and cal is None
    assert "column 'gz'" in res.stderr and "stuck" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    write_foreign_session(tmp_path / "a", stuck=("accel", 1))
    res, cal = calibrate(tmp_path / "a", tmp_path / "out_a")
    assert res.returncode == 3 and "column 'ay'" in res.stderr and "stuck" in res.stderr


def test_a_clip_away_from_the_adc_codes_is_found_by_its_pile(tmp_path):
    """An accelerometer axis clipped at 15000 counts (not a full-scale ADC code) in the holds where gravity is
    along it went into the fit: H 6 % off, exit 0."""
    truth = write_foreign_session(tmp_path / "s", clip=("accel", 2, 15000))
    res, cal = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    assert "saturated" in res.stdout
    assert h_error(cal, truth, "accel") < 1e-3


def test_t_in_milliseconds_against_the_sample_rate_is_refused(tmp_path):
    """t written in ms beside sample_rate_hz 100: refused naming t and the rate (exit 2), not read as seconds
    (once the 1 Hz logger's holds were kept, that calibrated the gyro 1000 times too small with exit 0)."""
    write_foreign_session(tmp_path / "s", t_scale=1000.0)
    res, cal = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 2 and cal is None
    assert "samples.csv, line 3, column 't'" in res.stderr and "sample_rate_hz" in res.stderr


def test_cells_padded_with_blanks_are_read(tmp_path):
    """"1, 2, , 4" (a printf-style logger): a blank-only cell reached numpy's parser as " ", and the refusal named
    numpy's "row 1, column 16" instead of a line of the file."""
    truth = write_foreign_session(tmp_path / "s", pad=True)
    res, cal = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    assert h_error(cal, truth, "gyro") < 2e-3


def test_a_blank_row_inside_the_data_is_named_once(tmp_path):
    """The reader's own error about a blank row was caught as the parser's and wrapped: "samples.csv: cannot be
    read as numbers: .../samples.csv, line N: ..."."""
    write_foreign_session(tmp_path / "s", n=6)
    path = tmp_path / "s" / "samples.csv"
    lines = path.read_text().split("\n")
    lines.insert(100, "")
    path.write_text("\n".join(lines))
    res, _ = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 2
    assert "cannot be read as numbers" not in res.stderr and "line 101: empty row inside the data" in res.stderr


@pytest.mark.parametrize("what", ["settling", "no moves"])
def test_a_refusal_for_too_few_holds_or_moves_says_why(tmp_path, what):
    """0.5 s holds with the default 0.5 s settling: "accel: 0 usable orientations" alone, not that --settle-s had
    taken all 12 recorded ones; a logger that writes only its holds: "gyro: 0 usable moves" alone."""
    folder = tmp_path / "s"
    write_foreign_session(folder, hold_s=0.5 if what == "settling" else 3.0)
    if what == "no moves":
        lines = (folder / "samples.csv").read_text().splitlines()
        (folder / "samples.csv").write_text("\n".join([lines[0], *[x for x in lines[1:] if ",move," not in x]]) + "\n")
    res, cal = calibrate(folder, tmp_path / "out")
    assert res.returncode == 3 and cal is None
    if what == "settling":
        assert "12 of 12 holds are shorter than the settling time 0.5 s (--settle-s)" in res.stderr
    else:
        assert "no 'move' rows" in res.stderr


def test_quaternions_written_world_to_fixture_are_named(tmp_path):
    """Another tool's reference written the other way round (world -> fixture, the conjugate): the calibration had
    blamed the schedule ("the reference directions are coplanar"), the discrepancy analysis said the linear model
    explains everything (exit 0) and the attitude comparison gave 120 deg RMS (exit 0). Each now says which way
    the quaternions turn and what to do, before anything is fitted to them."""
    folder = tmp_path / "s"
    write_foreign_session(folder)
    lines = (folder / "samples.csv").read_text().splitlines()
    head = lines[0].split(",")
    vector = [head.index(c) for c in ("qx", "qy", "qz")]
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        for i in vector:
            row[i] = row[i][1:] if row[i].startswith("-") else "-" + row[i]
    (folder / "samples.csv").write_text("\n".join([lines[0]] + [",".join(r) for r in rows]) + "\n")

    res, cal = calibrate(folder, tmp_path / "c")
    assert res.returncode == 3 and cal is None, res.stderr
    assert "world -> fixture" in res.stderr and "negate qx, qy and qz" in res.stderr, res.stderr
    res = subprocess.run([*RIG, "discrepancy", str(folder), "--json", str(tmp_path / "d.json")], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 3 and "world -> fixture" in res.stderr and "Traceback" not in res.stderr, res.stderr
