"""Where a calibration is applied to a session (attitude), a temperature model applies at each row's die
temperature, and a row outside its range refuses the whole application by name."""

import numpy as np
import pytest

from rig.attitude.evaluate import calibrated_signals
from rig.calibration.thermal import TemperatureOutOfRange, fit_thermal_model
from rig.io.calibration_json import read_calibration, triads_from_calibration, write_calibration
from rig.session_data import SessionData

from thermal_synth import G, make_unit, thermal_steps


@pytest.fixture
def calibration(tmp_path):
    rng = np.random.default_rng(41)
    models = {s: fit_thermal_model(s, thermal_steps(make_unit(s, rng), rng)) for s in ("accel", "gyro")}
    path = write_calibration(tmp_path / "calibration.json",
                             {s: m.calibration_at(m.reference_c) for s, m in models.items()},
                             gravity=G, field_uT=None, temperature_models=models)
    return triads_from_calibration(read_calibration(path)), models


def _session(temp_c, rng):
    n = len(temp_c)
    return SessionData(t=np.arange(n) * 0.01, is_move=np.zeros(n, bool), step=np.zeros(n, int),
                       q_ref=np.tile([1.0, 0, 0, 0], (n, 1)),
                       raw={"accel": rng.normal(0, 8000, (n, 3)), "gyro": rng.normal(0, 100, (n, 3))},
                       columns={"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"]}, temp_c=np.asarray(temp_c))


def test_each_row_at_its_temperature(calibration):
    triads, models = calibration
    session = _session([0.0, 20.0, np.nan, 50.0], np.random.default_rng(1))
    u = calibrated_signals(session, triads)
    for name, model in models.items():
        want = model.apply_at(session.raw[name][[0, 1, 3]], [0.0, 20.0, 50.0])
        np.testing.assert_allclose(u[name][[0, 1, 3]], want, rtol=1e-10, atol=1e-10 * np.abs(want).max())
        assert np.isnan(u[name][2]).all()
        constant = triads[name].apply(session.raw[name][[0]])
        assert not np.allclose(u[name][0], constant, rtol=1e-7, atol=0)    # 0 C is not the reference's


def test_outside_the_range_is_refused(calibration):
    triads, _ = calibration
    with pytest.raises(TemperatureOutOfRange, match=r"sensor '(accel|gyro)': die temperature 80.00 C"):
        calibrated_signals(_session([20.0, 80.0], np.random.default_rng(2)), triads)
