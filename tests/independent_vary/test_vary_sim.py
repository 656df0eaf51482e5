"""The second independent simulator: its own conventions checked against scipy, then `rig calibrate --from`
checked against the truth it knows, for the variants most likely to differ from our own choices."""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).parent))
import vary_sim as vs  # noqa: E402

H_TARGET_PCT = 0.05
B_TARGET_PCT = 0.1


def scipy_table(outer_deg: float, inner_deg: float) -> Rotation:
    """Fixture -> world rotation of conventions.md, R = Rx(outer) Rz(inner), as scipy composes it."""
    return Rotation.from_euler("x", outer_deg, degrees=True) * Rotation.from_euler("z", inner_deg, degrees=True)


# ---------------------------------------------------------------- conventions of the simulator
@pytest.mark.parametrize("outer,inner", [(0, 0), (30, 0), (0, 40), (115.3, -72.9), (250, 181), (-179, 359)])
def test_table_quaternion_matches_scipy(outer: float, inner: float) -> None:
    q = vs.table_quat(np.array(outer * vs.DEG), np.array(inner * vs.DEG))
    x, y, z, w = scipy_table(outer, inner).as_quat()
    expected = np.array([w, x, y, z])
    assert np.allclose(q * np.sign(q[0] or 1), expected * np.sign(w or 1), atol=1e-12)
    assert np.allclose(vs.rot_x(outer * vs.DEG) @ vs.rot_z(inner * vs.DEG),
                       scipy_table(outer, inner).as_matrix(), atol=1e-12)
    assert np.allclose(vs.quat_to_matrix(q), scipy_table(outer, inner).as_matrix(), atol=1e-12)


def test_quaternion_rotates_fixture_vectors_to_world() -> None:
    """v_world = q v_fixture q*: a quarter turn of the outer axis takes fixture y to world z."""
    q = vs.table_quat(np.array(90 * vs.DEG), np.array(0.0))
    v = np.array([0.0, 0.0, 1.0, 0.0])
    conj = q * np.array([1, -1, -1, -1])
    assert np.allclose(vs.quat_mul(vs.quat_mul(q, v), conj)[1:], [0, 0, 1], atol=1e-12)


def test_hamilton_product_and_exp_match_scipy() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=3), rng.normal(size=3)
    qa, qb = vs.quat_exp(a), vs.quat_exp(b)
    x, y, z, w = (Rotation.from_rotvec(a) * Rotation.from_rotvec(b)).as_quat()
    prod = vs.quat_mul(qa, qb)
    assert np.allclose(prod * np.sign(prod[0]), np.array([w, x, y, z]) * np.sign(w), atol=1e-12)


def test_body_rate_and_accel_match_finite_differences_of_scipy_rotations() -> None:
    """omega_fixture from R^T dR/dt of the scipy-composed table rotation along a smooth path."""
    t, h = 0.37, 1e-5
    a = lambda s: 40 * np.sin(1.3 * s) + 10 * s  # noqa: E731  deg
    b = lambda s: 70 * np.cos(0.9 * s) - 25 * s  # noqa: E731
    rot = lambda s: scipy_table(a(s), b(s))  # noqa: E731
    omega_fd = (rot(t).inv() * rot(t + h)).as_rotvec() / (2 * h) + (rot(t - h).inv() * rot(t)).as_rotvec() / (2 * h)
    d = lambda f, s: (f(s + h) - f(s - h)) / (2 * h)  # noqa: E731
    dd = lambda f, s: (f(s + h) - 2 * f(s) + f(s - h)) / h**2  # noqa: E731
    omega = vs.body_rate(d(a, t) * vs.DEG, b(t) * vs.DEG, d(b, t) * vs.DEG)
    assert np.allclose(omega, omega_fd, rtol=1e-6, atol=1e-8)
    w = lambda s: vs.body_rate(d(a, s) * vs.DEG, b(s) * vs.DEG, d(b, s) * vs.DEG)  # noqa: E731
    alpha = vs.body_accel(d(a, t) * vs.DEG, dd(a, t) * vs.DEG, b(t) * vs.DEG, d(b, t) * vs.DEG, dd(b, t) * vs.DEG)
    assert np.allclose(alpha, (w(t + 1e-4) - w(t - 1e-4)) / 2e-4, rtol=1e-4, atol=1e-6)


def test_static_level_accelerometer_sees_plus_g_and_mag_points_down() -> None:
    cfg = vs.Config()
    tl = vs.Timeline(vs.AxisPath(0.0), vs.AxisPath(0.0), np.array([0.0]), np.array([10.0]), 10.0)
    assert np.allclose(vs.accel_truth(cfg, tl, np.array([1.0])), [[0, 0, cfg.gravity]])
    assert vs.mag_truth(cfg, tl, np.array([1.0]))[0, 2] < -0.8 * cfg.field_uT


@pytest.mark.parametrize("d,vmax,amax", [(90.0, 60.0, 120.0), (-200.0, 15.0, 30.0), (3.0, 200.0, 800.0)])
def test_trapezoid_integrates_to_its_distance(d: float, vmax: float, amax: float) -> None:
    mv = vs.Move(1.0, 10.0, d, vmax, amax)
    t = np.linspace(0.0, 1.0 + mv.duration + 1.0, 400001)
    pos, vel, acc = mv.state(t)
    assert pos[-1] == pytest.approx(10.0 + d, abs=1e-9)
    assert np.trapezoid(vel, t) == pytest.approx(d, rel=1e-6)
    assert np.abs(vel).max() <= vmax + 1e-9
    assert np.abs(np.diff(vel) / np.diff(t)).max() <= amax * (1 + 1e-6)


def test_gyro_truth_integrates_to_reference_rotation_over_a_move() -> None:
    """Integrating the gyro truth over a move gives R_j^T R_{j+1} (conventions.md). A filtered rate is a
    lagged rate, and rotations do not commute, so the filtered models are allowed a 1e-5-relative residue."""
    for model, tol in (("instant", 2e-6), ("mean", 5e-5), ("lpf", 5e-5)):
        cfg = replace(vs.Config(), gyro_model=model, n_orient=3)
        rng = np.random.default_rng(0)
        ang = np.array([[10.0, 20.0], [100.0, -60.0], [0.0, 0.0]])
        tl = vs.build_timeline(cfg, ang, rng)
        t = np.arange(tl.hold_end[0] - 0.5, tl.hold_start[1] + 0.5, 1e-3)
        w = vs.gyro_truth(cfg, tl, t, 1000.0)
        rot = Rotation.identity()
        for k in range(len(t) - 1):
            rot = rot * Rotation.from_rotvec(0.5 * (w[k] + w[k + 1]) * (t[k + 1] - t[k]))
        expected = scipy_table(*ang[0]).inv() * scipy_table(*ang[1])
        assert (expected.inv() * rot).magnitude() < tol, model


def test_truth_round_trip_u_equals_H_y_minus_B() -> None:
    rng = np.random.default_rng(5)
    for kind in ("small", "rot90", "perm"):
        s = vs.make_sensor("mag", replace(vs.Config(), mount=kind), rng, vs.mounting(kind, rng))
        u = np.array([10.0, -20.0, 30.0])
        assert np.allclose(s.H @ ((s.K @ u + s.B) - s.B), u)
        assert np.linalg.det(s.H) > 0


def test_session_files_follow_the_layout(tmp_path: Path) -> None:
    cfg = vs.config_for("multirate_mag10")
    truth = vs.write_session(vs.generate(cfg, 0), tmp_path / "s")
    meta = json.loads((tmp_path / "s" / "meta.json").read_text())
    lines = (tmp_path / "s" / "samples.csv").read_text().splitlines()
    header = lines[0].split(",")
    rows = [r.split(",") for r in lines[1:]]
    t = np.array([float(r[0]) for r in rows])
    assert np.all(np.diff(t) > 0)
    mx = header.index(meta["sensors"]["mag"][0])
    filled = sum(1 for r in rows if r[mx] != "")
    assert filled == pytest.approx(len(rows) * 10 / 200, rel=0.02)
    assert {r[1] for r in rows} == {"hold", "move"}
    assert json.loads(truth.read_text()).keys() == {"accel", "gyro", "mag"}


# ---------------------------------------------------------------- our tool against this simulator
# mount_rot90, mount_perm, mount_flip and hold_early_long failed when this simulator was first run (gyro start
# point; fixed settling time); fast_mean_50hz came within 0.006 % of the H target (mean samples read as point
# rates); gyro_lpf20ms keeps a lagging gyro honest: see FINDINGS.md.
VARIANTS = ["baseline", "rate200", "rate50", "gyro_mean", "gyro_lpf5ms", "optical", "optical_signflip",
            "unix_jitter_drop", "multirate_mag75", "multirate_mag10", "revisit", "fullscale", "lever_arm",
            "hold_early", "slow_moves", "fast_moves", "long_moves", "sequential_axes", "unequal_holds",
            "odd_columns", "no_mag", "step_from_1", "extra_columns", "mount_rot30",
            "mount_rot90", "mount_perm", "mount_flip", "hold_early_long", "fast_mean_50hz", "gyro_lpf20ms"]
EXTRA_ARGS: dict[str, tuple[str, ...]] = {}


@pytest.mark.parametrize("variant", VARIANTS)
def test_rig_calibrate_meets_targets(variant: str, tmp_path: Path) -> None:
    session = vs.generate(vs.config_for(variant), seed=11)
    truth_path = vs.write_session(session, tmp_path / "session")
    proc = vs.run_cli(tmp_path / "session", tmp_path / "out", *EXTRA_ARGS.get(variant, ()))
    assert proc.returncode == 0, proc.stderr
    cal = json.loads((tmp_path / "out" / "calibration.json").read_text())
    errors = vs.score(cal, json.loads(truth_path.read_text()))
    for name, e in errors.items():
        assert e["H_err_pct"] <= H_TARGET_PCT, (name, e)
        assert e["B_err_pct"] <= B_TARGET_PCT, (name, e)
        assert np.linalg.det(np.asarray(cal["sensors"][name]["H"])) > 0
