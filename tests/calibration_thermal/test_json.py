"""`sensors.<s>.temperature_model` in calibration.json: written, read back typed, a broken one named by key."""

import json

import numpy as np
import pytest

from rig.calibration.thermal import FORMAT_VERSION, TemperatureOutOfRange, fit_thermal_model
from rig.io.calibration_json import (CalibrationFileError, read_calibration, temperature_models_from_calibration,
                                     triads_from_calibration, write_calibration)

from thermal_synth import G, make_unit, thermal_steps


@pytest.fixture
def written(tmp_path):
    rng = np.random.default_rng(17)
    models, sensors = {}, {}
    for sensor in ("accel", "gyro"):
        steps = thermal_steps(make_unit(sensor, rng), rng)
        models[sensor] = fit_thermal_model(sensor, steps)
        sensors[sensor] = models[sensor].calibration_at(models[sensor].reference_c)
    path = write_calibration(tmp_path / "calibration.json", sensors, gravity=G, field_uT=None,
                             temperature_models=models)
    return path, models


def test_round_trip_gives_the_same_model(written):
    path, models = written
    back = temperature_models_from_calibration(read_calibration(path), path)
    assert set(back) == {"accel", "gyro"}
    y = np.random.default_rng(1).normal(0, 5000, (5, 3))
    for name, model in models.items():
        got = back[name]
        assert got.format_version == FORMAT_VERSION and got.sensor == name
        assert got.valid_c == pytest.approx(model.valid_c) and got.reference_c == pytest.approx(model.reference_c)
        assert got.B.orders == model.B.orders and got.H.orders == model.H.orders
        temps = np.linspace(*model.valid_c, 5)
        want = model.apply_at(y, temps)
        np.testing.assert_allclose(got.apply_at(y, temps), want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
        np.testing.assert_allclose(got.calibration_at(temps[1]).B_std, model.calibration_at(temps[1]).B_std,
                                   rtol=1e-9)
        with pytest.raises(TemperatureOutOfRange, match=name):
            got.apply_at(y, model.valid_c[1] + 1.0)


def test_the_constant_calibration_keeps_its_meaning(written):
    path, models = written
    triads = triads_from_calibration(read_calibration(path))
    for name, model in models.items():
        np.testing.assert_allclose(triads[name].B, model.B_at(model.reference_c), rtol=1e-12)
        assert "temperature_model" in triads[name].extra      # kept where a calibration is written again


@pytest.mark.parametrize("edit, key", [
    (lambda m: m.update(format_version=2), "sensors.gyro.temperature_model.format_version"),
    (lambda m: m.update(valid_c=[40.0, 10.0]), "sensors.gyro.temperature_model.valid_c"),
    (lambda m: m["B"]["order"].pop(), "sensors.gyro.temperature_model.B.order"),
    (lambda m: m["H"]["coefficients"][4].append(1.0), "sensors.gyro.temperature_model.H.coefficients[4]"),
    (lambda m: m["B"].update(covariance=[[1.0]]), "sensors.gyro.temperature_model.B.covariance"),
])
def test_a_broken_model_is_named_by_key(written, edit, key):
    path, _ = written
    doc = json.loads(path.read_text())
    edit(doc["sensors"]["gyro"]["temperature_model"])
    path.write_text(json.dumps(doc))
    with pytest.raises(CalibrationFileError) as info:
        read_calibration(path)
    assert info.value.key == key and str(path) in str(info.value)
