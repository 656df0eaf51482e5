"""The lever-arm estimator on motion whose specific force is known in closed form, and the pipeline storing
it for a session of the second, independent simulator (tests/independent_vary/vary_sim.py)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "independent_vary"))
import vary_sim as vs  # noqa: E402

from rig.calibration.turntable.lever_arm import compensate, estimate_lever_arm  # noqa: E402

G = 9.80665
RATE_HZ = 200.0


def table_motion(duration_s: float = 40.0):
    """Both axes swinging (deg): R = Rx(a) Rz(b), its body rate and angular acceleration from the
    simulator's closed forms, not from the estimator's finite differences."""
    t = np.arange(0.0, duration_s, 1.0 / RATE_HZ)
    a = 80 * np.sin(0.5 * t) + 30 * np.sin(1.3 * t)
    ad = 40 * np.cos(0.5 * t) + 39 * np.cos(1.3 * t)
    add = -20 * np.sin(0.5 * t) - 50.7 * np.sin(1.3 * t)
    b = 120 * np.sin(0.4 * t + 1) + 40 * np.sin(1.7 * t)
    bd = 48 * np.cos(0.4 * t + 1) + 68 * np.cos(1.7 * t)
    bdd = -19.2 * np.sin(0.4 * t + 1) - 115.6 * np.sin(1.7 * t)
    d = vs.DEG
    R = vs.rot_x(a * d) @ vs.rot_z(b * d)
    w = vs.body_rate(ad * d, b * d, bd * d)
    dw = vs.body_accel(ad * d, add * d, b * d, bd * d, bdd * d)
    return t, R, w, dw


def specific_force(R: np.ndarray, w: np.ndarray, dw: np.ndarray, r) -> np.ndarray:
    r = np.asarray(r, dtype=float)
    return G * R[:, 2, :] + np.cross(dw, r) + np.cross(w, np.cross(w, r))


def move_rows(t: np.ndarray) -> np.ndarray:
    """4.5 s 'moves' separated by 0.5 s gaps, so the fit sees several independent moves."""
    return np.flatnonzero((t % 5.0) < 4.5)


def noisy(rng, t, R, w, dw, r):
    accel = specific_force(R, w, dw, r) + rng.normal(0, 0.003, (len(t), 3))
    gyro = w + rng.normal(0, 0.0005, (len(t), 3))
    return accel, gyro


def test_recovers_a_known_lever_arm(rng) -> None:
    t, R, w, dw = table_motion()
    r_true = np.array([0.04, -0.07, 0.03])
    accel, gyro = noisy(rng, t, R, w, dw, r_true)
    fit = estimate_lever_arm(t, accel, gyro, R, G, move_rows(t))
    assert np.abs(fit.r_m - r_true).max() < 3e-4, fit
    assert (np.abs(fit.r_m - r_true) < 5 * fit.std_m + 5e-5).all(), fit
    assert (fit.std_m < 1e-3).all() and fit.significant and fit.p_value < 1e-6
    assert fit.rows_used == len(move_rows(t))


def test_no_lever_arm_comes_out_zero_within_its_std(rng) -> None:
    t, R, w, dw = table_motion()
    accel, gyro = noisy(rng, t, R, w, dw, np.zeros(3))
    fit = estimate_lever_arm(t, accel, gyro, R, G, move_rows(t))
    assert not fit.significant and fit.p_value > 2.7e-3, fit
    assert np.linalg.norm(fit.r_m) < 3e-4
    assert (np.abs(fit.r_m) < 4 * fit.std_m).all(), fit


def test_gyro_sampled_on_every_other_row_is_interpolated(rng) -> None:
    t, R, w, dw = table_motion()
    r_true = np.array([-0.05, 0.02, 0.08])
    accel, gyro = noisy(rng, t, R, w, dw, r_true)
    gyro[1::2] = np.nan
    fit = estimate_lever_arm(t, accel, gyro, R, G, move_rows(t))
    assert np.abs(fit.r_m - r_true).max() < 5e-4, fit


def test_compensation_leaves_gravity_only(rng) -> None:
    t, R, w, dw = table_motion()
    r = np.array([0.06, -0.08, 0.05])
    accel, gyro = noisy(rng, t, R, w, dw, r)
    gravity_only = G * R[:, 2, :]
    before = np.sqrt(np.mean((accel - gravity_only) ** 2))
    after = np.sqrt(np.mean((compensate(t, accel, gyro, r) - gravity_only)[20:-20] ** 2))
    assert before > 0.05
    assert after < 0.01, (before, after)


def test_compensation_keeps_rows_without_an_accel_sample_empty(rng) -> None:
    t, R, w, dw = table_motion(5.0)
    accel, gyro = noisy(rng, t, R, w, dw, [0.05, 0.0, 0.0])
    accel[::3] = np.nan
    out = compensate(t, accel, gyro, [0.05, 0.0, 0.0])
    assert np.isnan(out[::3]).all() and np.isfinite(out[1::3]).all()


def test_turning_about_one_axis_only_is_refused() -> None:
    """With the outer axis still, the inner axis' rotation cannot see the accelerometer's height along it."""
    t = np.arange(0.0, 20.0, 1.0 / RATE_HZ)
    b = 90 * np.sin(0.8 * t)
    R = vs.rot_x(np.zeros_like(t)) @ vs.rot_z(b * vs.DEG)
    w = vs.body_rate(np.zeros_like(t), b * vs.DEG, 72 * np.cos(0.8 * t) * vs.DEG)
    dw = vs.body_accel(np.zeros_like(t), np.zeros_like(t), b * vs.DEG, 72 * np.cos(0.8 * t) * vs.DEG,
                       -57.6 * np.sin(0.8 * t) * vs.DEG)
    accel = specific_force(R, w, dw, [0.03, 0.02, 0.05])
    with pytest.raises(ValueError, match="enough axes"):
        estimate_lever_arm(t, accel, w, R, G, move_rows(t))


def test_rows_with_an_empty_accel_are_refused(rng) -> None:
    t, R, w, dw = table_motion(5.0)
    accel, gyro = noisy(rng, t, R, w, dw, np.zeros(3))
    accel[10] = np.nan
    with pytest.raises(ValueError, match="finite"):
        estimate_lever_arm(t, accel, gyro, R, G, np.arange(len(t)))


# ---------------------------------------------------------------- the pipeline on the independent simulator
@pytest.fixture(scope="module")
def lever_arm_calibration(tmp_path_factory):
    from rig.pipeline import calibrate_from_dir

    d = tmp_path_factory.mktemp("lever")
    vs.write_session(vs.generate(vs.config_for("lever_arm"), 3), d / "s")
    result = calibrate_from_dir(d / "s", d / "out", echo=lambda *_: None)
    return result, d / "out" / "calibration.json"


def test_pipeline_stores_the_lever_arm_of_a_session(lever_arm_calibration) -> None:
    result, _ = lever_arm_calibration
    extra = result.sensors["accel"].extra
    truth = np.array(vs.config_for("lever_arm").lever_arm_m)
    assert np.abs(np.array(extra["lever_arm_m"]) - truth).max() < 1e-3, extra
    assert extra["lever_arm_significant"] is True
    assert (np.array(extra["lever_arm_std_m"]) < 1e-3).all()
    assert any("lever arm r =" in line and "(significant" in line for line in result.summary)


def test_lever_arm_survives_the_calibration_file(lever_arm_calibration) -> None:
    from rig.io.calibration_json import read_calibration, triads_from_calibration

    result, path = lever_arm_calibration
    back = triads_from_calibration(read_calibration(path))["accel"].extra
    for key in ("lever_arm_m", "lever_arm_std_m", "lever_arm_significant", "lever_arm_p_value"):
        assert back[key] == result.sensors["accel"].extra[key], key


def test_a_failed_lever_arm_fit_is_a_warning_not_a_failure(monkeypatch, tmp_path) -> None:
    import rig.calibration.turntable.lever_arm as lever_arm
    from rig.io.session_csv import read_session
    from rig.pipeline import calibrate_session

    def refuse(*args, **kwargs):
        raise ValueError("the moves do not turn about enough axes to locate the accelerometer")

    monkeypatch.setattr(lever_arm, "estimate_lever_arm", refuse)
    vs.write_session(vs.generate(vs.config_for("lever_arm"), 4), tmp_path / "s")
    result = calibrate_session(read_session(tmp_path / "s"))
    assert "lever_arm_m" not in result.sensors["accel"].extra
    assert any(w.startswith("accel: no lever arm estimate (the moves do not turn") for w in result.warnings)
