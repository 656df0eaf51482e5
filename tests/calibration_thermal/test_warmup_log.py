"""The warm-up fit (rig/noise/thermal_warmup.py) on still logs of a board warming, beside PX4's and ArduPilot's.

No public warming log whose licence allows copying it here was found (docs/guides/temperature.md, "Real data",
lists what was searched), so the logs are simulated (warmup_synth: the world's sensor, noise and bias instability,
a thermometer that reads the die with noise and rounds it) and the fit runs blind: it is told neither the curve's
shape nor its order. The route a real log takes is tested end to end: a CSV with a temperature column, imported as
a user would, then fitted.

Margins are the data's own: "no worse than a peer" is the paired difference of the per-log mean squared held-out
errors within two of its standard errors; "at the noise floor" the mean of our squared standardised errors (error
over what the band's and our prediction's deviations say, chi-square with one degree of freedom each were both
exact) within three of its standard errors, sqrt(2 / N), of 1.
"""

import numpy as np
import pytest

from rig.calibration.thermal.model import TemperatureOutOfRange
from rig.noise.thermal_warmup import fit_warmup, fit_warmup_session, held_out
from rig.errors import InputError
from rig.io.import_csv import import_csv

from warmup_synth import campaign, true_offset, warmup_log

SEEDS = 4
PEERS = ("px4", "ardupilot")


@pytest.fixture(scope="module")
def gyro_cubic():
    return campaign("gyro", "cubic", SEEDS, seed=11)


@pytest.fixture(scope="module")
def gyro_flat():
    return campaign("gyro", "flat", SEEDS, seed=12)


@pytest.fixture(scope="module")
def accel_linear():
    return campaign("accel", "linear", SEEDS, seed=13)


def _no_worse_than_peers(runs):
    ours = np.array([np.mean(r["held"].errors["ours"] ** 2) for r in runs])
    for peer in PEERS:
        theirs = np.array([np.mean(r["held"].errors[peer] ** 2) for r in runs])
        d = ours - theirs
        se = d.std(ddof=1) / np.sqrt(d.size)
        assert d.mean() <= 2.0 * se, (peer, ours, theirs)


@pytest.mark.parametrize("which", ["gyro_cubic", "gyro_flat", "accel_linear"])
def test_held_out_prediction_is_no_worse_than_the_peers(which, request):
    runs = request.getfixturevalue(which)
    assert all(not r["held"].skipped for r in runs), [r["held"].skipped for r in runs]
    _no_worse_than_peers(runs)


@pytest.mark.parametrize("which", ["gyro_cubic", "accel_linear"])
def test_held_out_error_is_what_the_noise_leaves(which, request):
    z = np.concatenate([r["held"].standardised().ravel() for r in request.getfixturevalue(which)])
    assert np.mean(z ** 2) <= 1.0 + 3.0 * np.sqrt(2.0 / z.size)


def test_a_curved_offset_gets_the_order_that_follows_it(gyro_cubic):
    orders = np.array([r["fit"].curves.orders for r in gyro_cubic]).ravel()
    assert np.mean(orders == 3) >= 0.75, orders


def test_an_offset_that_does_not_move_is_not_given_a_curve(gyro_flat):
    orders = np.array([r["fit"].curves.orders for r in gyro_flat]).ravel()
    assert np.mean(orders > 0) <= 0.25, orders


def test_a_linear_tempco_is_recovered_within_its_stated_deviation(accel_linear):
    for r in accel_linear:
        fit, log = r["fit"], r["log"]
        dT = 1e-3
        true_slope = (true_offset(log, fit.reference_c + dT) - true_offset(log, fit.reference_c - dT))[0] / (2 * dT)
        col = 0
        for axis, order in enumerate(fit.curves.orders):
            assert order >= 1, fit.curves.orders
            slope, std = fit.curves.coefficients[axis][1], np.sqrt(fit.curves.covariance[col + 1, col + 1])
            assert abs(slope - true_slope[axis]) <= 3.0 * std, (axis, slope, true_slope[axis], std)
            col += order + 1


def test_outside_the_logged_temperatures_the_fit_is_refused(gyro_flat):
    fit = gyro_flat[0]["fit"]
    lo, hi = fit.valid_c
    fit.offset_at([lo, 0.5 * (lo + hi), hi])
    with pytest.raises(TemperatureOutOfRange, match="gyro"):
        fit.offset_at(hi + 0.5)


@pytest.fixture(scope="module")
def log_csv(tmp_path_factory):
    log = warmup_log(np.random.default_rng(21), "gyro", "cubic", duration_s=1200.0)
    s = log.session
    path = tmp_path_factory.mktemp("warmup") / "warmup_log.csv"
    rows = np.column_stack([s.t, s.raw["gyro"], s.temp_c])
    np.savetxt(path, rows, delimiter=",", header="time_s,gyro_x,gyro_y,gyro_z,die_temp_c", comments="",
               fmt=["%.4f", "%d", "%d", "%d", "%.5f"])
    return path, log


def test_a_log_imported_with_its_temperature_column_is_fitted_as_its_arrays(log_csv):
    path, log = log_csv
    session = import_csv(path, {"gyro": ["gyro_x", "gyro_y", "gyro_z"]}, units={"gyro": "counts"},
                         time_column="time_s", temp_column="die_temp_c")
    assert session.temp_c is not None and len(session.temp_c) == len(log.session.t)
    from_file = fit_warmup_session(session, "gyro")
    direct = fit_warmup("gyro", np.round(log.session.temp_c, 5), log.session.raw["gyro"],
                        rate_hz=log.session.sample_rate_hz)
    assert from_file.curves.orders == direct.curves.orders
    for a, b in zip(from_file.curves.coefficients, direct.curves.coefficients):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9 * np.abs(b).max())
    held = held_out("gyro", session.temp_c, session.raw["gyro"], rate_hz=50.0)
    assert set(held.errors) == {"ours", *PEERS}


def test_a_log_without_its_temperature_is_refused_by_name(log_csv):
    path, _ = log_csv
    session = import_csv(path, {"gyro": ["gyro_x", "gyro_y", "gyro_z"]}, units={"gyro": "counts"},
                         time_column="time_s")
    with pytest.raises(InputError, match="no temperature column.*--temp"):
        fit_warmup_session(session, "gyro")
    with pytest.raises(InputError, match="no 'accel'"):
        fit_warmup_session(import_csv(path, {"gyro": ["gyro_x", "gyro_y", "gyro_z"]}, units={"gyro": "counts"},
                                      time_column="time_s", temp_column="die_temp_c"), "accel")


def test_a_log_that_hardly_warms_is_refused_naming_the_sensor():
    rng = np.random.default_rng(5)
    n = 600
    temp = 25.0 + np.round(rng.normal(0.0, 0.002, n) / 0.01) * 0.01
    with pytest.raises(InputError, match="'gyro'.*temperature band"):
        fit_warmup("gyro", temp, rng.normal(0.0, 1.0, (n, 3)))


def test_a_log_in_which_the_unit_moved_is_refused(log_csv):
    path, _ = log_csv
    session = import_csv(path, {"gyro": ["gyro_x", "gyro_y", "gyro_z"]}, units={"gyro": "counts"},
                         time_column="time_s", temp_column="die_temp_c")
    turning = slice(len(session.t) // 3, len(session.t) // 3 + 500)            # 10 s turned by hand
    session.raw["gyro"][turning, 2] += 30.0 * 14.375
    with pytest.raises(InputError, match="gyro's z axis.*moved"):
        fit_warmup_session(session, "gyro")
