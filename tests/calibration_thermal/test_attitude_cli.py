"""`rig attitude` with a calibration that carries temperature models refuses a session whose die temperature lies
outside their range: exit 2, the sensor, temperature and range named (inside it, test_apply.py)."""

from __future__ import annotations

import numpy as np
from click.testing import CliRunner

from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.thermal import ThermalStep, fit_thermal_model
from rig.commands.attitude import attitude
from rig.io.calibration_json import write_calibration
from rig.io.session_writer import write_session
from tests.io.io_synthetic import build_session


def _flat_model(name: str, B: np.ndarray, H: np.ndarray):
    """A temperature model of a unit that does not move, fitted to 5 steps from 0 to 50 C."""
    rng = np.random.default_rng(0)
    b_std, h_std = 1e-3 * np.abs(B).max() + 1e-3, 1e-6 * np.abs(H).max()
    steps = [ThermalStep(t, TriadCalibration(B=B + b_std * rng.standard_normal(3),
                                             H=H + h_std * rng.standard_normal((3, 3)), method="step",
                                             B_std=np.full(3, b_std), H_std=np.full((3, 3), h_std)))
             for t in np.linspace(0.0, 50.0, 5)]
    return fit_thermal_model(name, steps)


def test_attitude_outside_the_range_is_refused(tmp_path):
    session, truth = build_session(seed=3, hold_s=2.0)
    session.temp_c = np.full(session.t.size, 25.0)
    session.temp_c[-10:] = 80.0
    folder = write_session(session, tmp_path / "s")
    sensors = {n: TriadCalibration(B=truth.B[n], H=truth.H[n], method="truth") for n in session.raw}
    models = {n: _flat_model(n, truth.B[n], truth.H[n]) for n in session.raw}
    cal = write_calibration(tmp_path / "cal.json", sensors, gravity=session.gravity, field_uT=session.field_uT,
                            temperature_models=models)
    done = CliRunner().invoke(attitude, [str(folder), "--calibration", str(cal), "--no-peers"])
    assert done.exit_code == 2, done.output
    assert "die temperature 80.00 C is outside the temperature model's range 0.00 .. 50.00 C" in done.output
    assert "Traceback" not in done.output
