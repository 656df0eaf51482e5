"""The temperature model: what it predicts between the steps, the deviations it states, the range it refuses."""

import numpy as np
import pytest

from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.thermal import TemperatureOutOfRange, ThermalStep, fit_thermal_model
from rig.exits import Exit, code_for

from thermal_synth import STEPS_C, held_out_temps, make_unit, thermal_steps


def test_stated_deviation_matches_the_error_between_steps():
    """Across units, the error of B(T) and H(T) at held-out temperatures, in units of the deviation the model
    states there, scatters as a unit normal (orders told, so the test is of the covariance, not the choice)."""
    rng = np.random.default_rng(11)
    zB, zH = [], []
    for _ in range(40):
        unit = make_unit("gyro", rng, "cubic")
        model = fit_thermal_model("gyro", thermal_steps(unit, rng), orders=unit.true_orders())
        for t in held_out_temps():
            cal = model.calibration_at(t)
            zB.extend((cal.B - unit.B(t)) / cal.B_std)
            zH.extend(((cal.H - unit.H(t)) / cal.H_std).ravel())
    for z in (np.asarray(zB), np.asarray(zH)):
        rms = float(np.sqrt(np.mean(z ** 2)))
        n = z.size
        assert abs(rms - 1.0) < 4 * np.sqrt(0.5 / n) + 0.15, rms


def test_reference_is_the_middle_and_range_the_steps():
    rng = np.random.default_rng(3)
    steps = thermal_steps(make_unit("gyro", rng), rng)
    model = fit_thermal_model("gyro", steps)
    T = [s.temp_c for s in steps]
    assert model.valid_c == (min(T), max(T))
    assert model.reference_c == pytest.approx(0.5 * (min(T) + max(T)))


def test_apply_at_is_the_calibration_at_each_rows_temperature():
    rng = np.random.default_rng(5)
    unit = make_unit("accel", rng)
    model = fit_thermal_model("accel", thermal_steps(unit, rng))
    y = rng.normal(0, 8000, (4, 3))
    temps = np.array([0.0, 12.5, 30.0, 60.0])
    u = model.apply_at(y, temps)
    for row, t, got in zip(y, temps, u):
        want = model.calibration_at(t).apply(row[None])[0]
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("temp", [STEPS_C[0] - 5.0, STEPS_C[-1] + 3.0, float("nan")])
def test_outside_the_range_is_refused_by_name(temp):
    rng = np.random.default_rng(8)
    model = fit_thermal_model("gyro", thermal_steps(make_unit("gyro", rng), rng))
    with pytest.raises(TemperatureOutOfRange) as info:
        model.apply_at(np.zeros((3, 3)), np.array([25.0, temp, 25.0]))
    text = str(info.value)
    assert "'gyro'" in text and f"{model.valid_c[0]:.2f} .. {model.valid_c[1]:.2f} C" in text
    assert code_for(info.value) == Exit.BAD_INPUT
    with pytest.raises(TemperatureOutOfRange):
        model.calibration_at(temp)


def test_a_step_without_deviations_is_refused_naming_it():
    rng = np.random.default_rng(9)
    steps = thermal_steps(make_unit("gyro", rng), rng)
    bare = steps[2].calibration
    steps[2] = ThermalStep(steps[2].temp_c, TriadCalibration(B=bare.B, H=bare.H, method="bare"))
    with pytest.raises(ValueError, match=r"sensor 'gyro', step at .* C, B: .*no deviations"):
        fit_thermal_model("gyro", steps)
    with pytest.raises(ValueError, match="2 or more temperatures"):
        fit_thermal_model("gyro", steps[:1])


@pytest.mark.parametrize("n", [2, 3, 4])
def test_a_short_session_in_any_order_gives_a_straight_line_at_most(n):
    """Too few steps for a held-out test beyond a straight line: the model is the line (or less) through them,
    whatever order the steps come in, and still within its stated deviation of the truth between them."""
    rng = np.random.default_rng(50 + n)
    unit = make_unit("gyro", rng, "linear")
    steps = thermal_steps(unit, rng, np.linspace(0.0, 50.0, n))[::-1]
    model = fit_thermal_model("gyro", steps)
    assert max(model.B.orders + model.H.orders) <= 1
    assert model.valid_c == (min(s.temp_c for s in steps), max(s.temp_c for s in steps))
    cal = model.calibration_at(25.0)
    assert np.all(np.abs(cal.B - unit.B(25.0)) < 5 * cal.B_std)
