"""`vary_sim.py --schedule`: a session follows the plan it is given (the rig's plans run on this
simulator), so the option cannot be silently ignored: the holds sit at the given table angles, in the given
order, for the given lengths, and each move lasts its rest-to-rest trapezoid (straight, not the short way)
plus the settle time. A schedule that is not one is refused with a message, not a traceback."""
from __future__ import annotations

import csv
import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SIM = Path(__file__).parent / "vary_sim.py"
RATE_HZ = 100.0          # the baseline variant samples every sensor at 100 Hz
# 10 orientations, unequal short holds, one move of 340 deg on the outer axis (the short way would be 20 deg)
ANGLES = [(10.0, 20.0), (-170.0, 150.0), (170.0, -150.0), (45.5, 0.0), (45.5, 90.0), (-60.0, -30.0),
          (120.0, 170.0), (0.0, -120.0), (-90.0, 60.0), (30.0, 100.0)]
HOLDS = [0.6, 1.3, 0.8, 1.0, 0.7, 1.5, 0.9, 1.1, 0.6, 1.2]
SPEED, ACCEL, SETTLE = 120.0, 360.0, 0.3


def trapezoid_s(distance: float, speed: float, accel: float) -> float:
    """Rest-to-rest duration of a symmetric trapezoid (triangle when it cannot reach `speed`)."""
    d = abs(distance)
    peak = min(speed, math.sqrt(d * accel))
    return 0.0 if d == 0 else 2 * peak / accel + (d - peak * peak / accel) / peak


def run_sim(tmp_path: Path, schedule: dict) -> subprocess.CompletedProcess:
    path = tmp_path / "schedule.json"
    path.write_text(json.dumps(schedule))
    return subprocess.run([sys.executable, str(SIM), str(tmp_path / "s"), "--seed", "4", "--schedule", str(path)],
                          capture_output=True, text=True, timeout=120)


def test_session_follows_the_given_schedule(tmp_path: Path) -> None:
    proc = run_sim(tmp_path, {"orientations": ANGLES, "hold_s": HOLDS, "speed_dps": SPEED, "accel_dps2": ACCEL,
                              "settle_s": SETTLE})
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "s" / "samples.csv") as f:
        rows = list(csv.DictReader(f))
    phases = [(phase, list(group)) for (phase, _), group in
              itertools.groupby(rows, key=lambda r: (r["phase"], r["step"]))]
    holds = [g for phase, g in phases if phase == "hold"]
    moves = [g for phase, g in phases if phase == "move"]
    assert [int(g[0]["step"]) for g in holds] == list(range(len(ANGLES)))
    assert len(moves) == len(ANGLES) - 1
    for g, (outer, inner), hold_s in zip(holds, ANGLES, HOLDS):
        table = np.array([[float(r["table_outer_deg"]), float(r["table_inner_deg"])] for r in g])
        assert np.abs(table - [outer, inner]).max() < 1e-6
        assert len(g) / RATE_HZ == pytest.approx(hold_s, abs=1.01 / RATE_HZ)
    for g, a, b in zip(moves, ANGLES[:-1], ANGLES[1:]):
        expected = max(trapezoid_s(b[0] - a[0], SPEED, ACCEL), trapezoid_s(b[1] - a[1], SPEED, ACCEL)) + SETTLE
        assert len(g) / RATE_HZ == pytest.approx(expected, abs=1.01 / RATE_HZ)
    outer = np.array([float(r["table_outer_deg"]) for r in moves[1]])
    assert outer.min() < -160 and outer.max() > 160 and np.all(np.diff(outer) >= 0)   # straight through 0


def test_a_bad_schedule_is_refused_with_a_message(tmp_path: Path) -> None:
    proc = run_sim(tmp_path, {"orientations": ANGLES, "hold_s": HOLDS[:3], "speed_dps": SPEED, "accel_dps2": ACCEL})
    assert proc.returncode != 0
    assert "one positive hold length per orientation" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "s").exists()
