"""What `rig calibrate --from` calibrates with loads no scipy, filterpy or simulated hardware (issue 17, start-up).

The modules below are the calibration math of a recorded session (the vector and gyro solvers, the lever
arm, rotations, the session data, the recordings' fits and the pipeline itself). Each is imported in a fresh
interpreter, so one that pulls a heavy package in is named: the recordings' g-sensitivity test once took
scipy.stats along (0.6 s, on every `rig calibrate`, the simulated session's included).
"""

from __future__ import annotations

import subprocess
import sys

import pytest

CALIBRATION_PATH = ["rig.calibration.gyro", "rig.calibration.gyro_start", "rig.calibration.joint",
                    "rig.calibration.lever_arm", "rig.calibration.twostep", "rig.calibration.ellipsoid",
                    "rig.calibration.quantisation", "rig.calibration.integrate", "rig.rotations", "rig.quaternions",
                    "rig.session_data", "rig.unscented", "rig.calibration.regression", "rig.calibration.recording",
                    "rig.pipeline.run"]
HEAVY = {"scipy", "filterpy", "fixtures", "procedures", "drivers", "pymodbus", "matplotlib", "tqdm"}
LIGHT = {"drivers", "drivers.units"}     # the standard gravity the drivers scale by; the package loads nothing else


@pytest.mark.parametrize("module", CALIBRATION_PATH)
def test_calibration_module_loads_nothing_heavy(module):
    probe = f"import sys, {module}; print(' '.join(sorted(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    loaded = [m for m in done.stdout.split() if m not in LIGHT]
    heavy = sorted({m.split(".")[0] for m in loaded} & HEAVY)
    assert heavy == [], f"importing {module} loads {heavy}: {[m for m in loaded if m.split('.')[0] in heavy][:5]}"
