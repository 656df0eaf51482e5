"""Sequential holds: a hold ends when its means' standard error is what the plan asked."""

import subprocess
import sys

import numpy as np

from procedures.hold_quality import HoldTarget, mean_standard_error


def ar1(rng, n, rho, sd, offset=500.0):
    e = rng.normal(0, sd * np.sqrt(1 - rho**2), (n, 3))
    y = np.empty((n, 3))
    y[0] = rng.normal(0, sd, 3)
    for k in range(1, n):
        y[k] = rho * y[k - 1] + e[k]
    return offset + y


def test_the_standard_error_counts_correlation_and_quantisation():
    rng = np.random.default_rng(5)
    white = 500.0 + rng.normal(0, 2.0, (400, 3))
    np.testing.assert_allclose(mean_standard_error(white), 2.0 / 20, rtol=0.12)
    correlated = ar1(rng, 2000, 0.8, 2.0)
    # AR(1): the mean's variance is sd^2 / n (1 + rho) / (1 - rho), three times the white figure's standard error
    np.testing.assert_allclose(mean_standard_error(correlated), 2.0 / np.sqrt(2000) * 3, rtol=0.2)
    stuck = np.full((300, 3), 17.0)                   # well under a count of noise: the rounding does not average
    np.testing.assert_allclose(mean_standard_error(stuck), np.sqrt(1 / 12 / 300))


def test_a_hold_ends_when_it_has_what_the_first_asked_between_min_and_max():
    rng = np.random.default_rng(8)
    target = HoldTarget(hold_s=3.0, min_s=1.5, max_s=9.0, sensors=("accel",))
    first = {"accel": 500.0 + rng.normal(0, 2.0, (300, 3))}
    assert not target.done({"accel": first["accel"][:290]}, 2.9)      # the first hold runs its planned length
    assert target.done(first, 3.0)
    target.learn(first)
    quiet = {"accel": 500.0 + rng.normal(0, 2.0, (600, 3))}
    assert not target.done({"accel": quiet["accel"][:100]}, 1.0)      # never before min_s
    ends = [t for t in np.arange(1.5, 9.01, 0.5) if target.done({"accel": quiet["accel"][:int(t * 100)]}, t)]
    assert 2.0 <= ends[0] <= 3.5
    noisy = {"accel": ar1(rng, 900, 0.8, 2.0)}                       # correlated: needs longer than planned
    ends = [t for t in np.arange(1.5, 9.01, 0.5) if target.done({"accel": noisy["accel"][:int(t * 100)]}, t)]
    assert ends[0] > 6.0


def test_a_simulated_session_with_sequential_holds(tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text('[unit]\nboard = "bsn"\n[turntable]\nurl = "tcp://127.0.0.1:0"\nspeed_dps = 120.0\n'
                   'accel_dps2 = 360.0\n[schedule]\norientations = 12\nhold_s = 2.0\nsequential = true\n'
                   'hold_min_s = 1.5\nhold_max_s = 4.0\n')
    out = tmp_path / "s"
    res = subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--sim", "--config", str(cfg), "--no-progress",
                          "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    from rig.store import SessionStore

    holds = SessionStore.open(out).to_session_data().holds("accel")
    lengths = holds.t_end - holds.t_start + 0.01
    assert len(lengths) == 12
    assert np.all(lengths >= 1.5 - 0.02) and np.all(lengths <= 4.0 + 0.02)
    assert np.median(lengths) <= 2.5


def test_a_wrong_sequential_setting_names_the_field(tmp_path):
    from rig.config import load_config

    cfg = tmp_path / "rig.toml"
    cfg.write_text('[schedule]\nhold_s = 2.0\nsequential = true\nhold_min_s = 3.0\n')
    try:
        load_config(cfg)
    except ValueError as exc:
        assert "hold_min_s" in str(exc) and str(cfg) in str(exc)
    else:
        raise AssertionError("accepted hold_min_s > hold_s")
