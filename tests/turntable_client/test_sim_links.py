"""The simulated rig runs a whole session over every line the fake table speaks ([sim] table_link)."""

import json
import subprocess
import sys
from importlib import resources

import numpy as np
import pytest

from rig.store import SessionStore

RIG = [sys.executable, "-m", "rig.cli"]


@pytest.mark.parametrize("link, scheme", [("rtu-tcp", "rtu+socket"), ("rtu-pty", "rtu")])
def test_a_simulated_session_calibrates_over_the_link(tmp_path, link, scheme):
    config = tmp_path / "rig.toml"
    config.write_text(resources.files("rig.configs").joinpath("sim.toml").read_text()
                      + f'\n[sim]\ntable_link = "{link}"\n')
    out = tmp_path / "session"
    done = subprocess.run([*RIG, "calibrate", "--sim", "--config", str(config), "--orientations", "12",
                           "--no-progress", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    cal = json.loads((out / "calibration.json").read_text())["sensors"]
    truth = json.loads((out / "truth.json").read_text())["sensors"]
    for name in ("accel", "gyro", "mag"):
        H, Ht = np.array(cal[name]["H"]), np.array(truth[name]["H"])
        assert np.linalg.norm(H - Ht) / np.linalg.norm(Ht) < 2e-3, name
    with SessionStore.open(out) as store:
        assert store.metadata["config"]["sim"]["table_link"] == link
        assert store.metadata["table_url"].startswith(scheme + "://")


def test_an_unknown_table_link_is_refused_with_the_allowed_ones(tmp_path):
    config = tmp_path / "rig.toml"
    config.write_text(resources.files("rig.configs").joinpath("sim.toml").read_text() + '\n[sim]\ntable_link = "can"\n')
    done = subprocess.run([*RIG, "calibrate", "--sim", "--config", str(config), "--out", str(tmp_path / "s")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    assert "table_link" in done.stderr and "rtu-pty" in done.stderr and "Traceback" not in done.stderr
