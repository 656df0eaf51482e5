"""What `rig calibrate --from` calibrates with loads none of a running session's side: no simulated hardware, no
procedures (the layers above rig's math), no turntable client, plots or progress bar.

The modules below are the calibration math of a recorded session (the vector and gyro solvers, the lever arm,
rotations, the session data, the recordings' fits and the pipeline itself). Each is imported in a fresh
interpreter, so what actually loads is checked, through every library in between, and a module that pulls one of
these in is named.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

CALIBRATION_PATH = ["rig.calibration.turntable.gyro", "rig.calibration.turntable.gyro_start",
                    "rig.calibration.turntable.joint", "rig.calibration.turntable.lever_arm",
                    "rig.calibration.turntable.twostep", "rig.calibration.numerics.ellipsoid",
                    "rig.calibration.numerics.quantisation", "rig.calibration.numerics.integrate", "rig.rotations",
                    "rig.quaternions", "rig.session_data", "rig.calibration.numerics.regression",
                    "rig.calibration.recordings.recording", "rig.pipeline.run"]
RUNNING_SESSION = {"fixtures", "procedures", "pymodbus", "matplotlib", "tqdm"}


@pytest.mark.parametrize("module", CALIBRATION_PATH)
def test_calibration_module_loads_nothing_of_a_running_session(module):
    probe = f"import sys, {module}; print(' '.join(sorted(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    loaded = done.stdout.split()
    found = sorted({m.split(".")[0] for m in loaded} & RUNNING_SESSION)
    assert found == [], f"importing {module} loads {found}: {[m for m in loaded if m.split('.')[0] in found][:5]}"
