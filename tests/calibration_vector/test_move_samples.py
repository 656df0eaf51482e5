"""The accelerometer's and magnetometer's move samples: the estimator on synthetic moves with a
known sample-time offset and a known extra input, and the pipeline leaving out rows whose reference is stale."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from rig.calibration.turntable.bounds import cramer_rao
from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.turntable.move_samples import MoveSamples, calibrate_with_moves
from rig.pipeline.move_rows import reference_rate
from rig.rotations import TableGeometry
from rig.schedule import plan_orientations

sys.path.insert(0, str(Path(__file__).parents[1] / "independent_vary"))
import vary_sim as vs  # noqa: E402

NORM = 9.80665
RATE_HZ = 100.0
SIGMA = 0.012           # per sample, units (the sensor in its own units: counts = units here)
HOLD_SAMPLES = 100
OFFSET_S = 0.008        # samples taken this long before their time stamps
GEOMETRY = TableGeometry()


def moves_of(schedule, t_move: float = 1.2):
    """Table angles of smooth rest-to-rest moves between consecutive holds, as functions of time in the move."""
    a = np.array([o.outer_deg for o in schedule])
    b = np.array([o.inner_deg for o in schedule])
    t = np.arange(0.0, t_move, 1.0 / RATE_HZ)

    def angles(k: int, at: np.ndarray):
        s = (1 - np.cos(np.pi * np.clip(at, 0, t_move) / t_move)) / 2
        return a[k] + (a[k + 1] - a[k]) * s, b[k] + (b[k + 1] - b[k]) * s

    return t, angles, len(schedule) - 1


def synthetic(rng, extra_amplitude: float = 0.0, offsets=None):
    schedule = plan_orientations(10)
    R = GEOMETRY.rotation([o.outer_deg for o in schedule], [o.inner_deg for o in schedule])
    H = np.eye(3) + rng.uniform(-0.03, 0.03, (3, 3))
    K, B = np.linalg.inv(H), rng.uniform(-0.5, 0.5, 3)
    v = NORM * np.array([0.02, -0.01, 1.0]) / np.linalg.norm([0.02, -0.01, 1.0])
    noise = rng.normal(0, SIGMA, (len(R), HOLD_SAMPLES, 3))
    y_means = (np.einsum("kji,j->ki", R, v) @ K.T + B)[:, None, :] + noise
    t, angles, n_moves = moves_of(schedule)
    ys, Rs, ws, cs = [], [], [], []
    for k in range(n_moves):
        stamped = GEOMETRY.rotation(*angles(k, t))
        sampled = GEOMETRY.rotation(*angles(k, t - (OFFSET_S if offsets is None else offsets(k))))
        c = extra_amplitude * np.column_stack([np.sin(3 * t + k), np.cos(2 * t), np.sin(5 * t + 1)])
        ys.append((np.einsum("kji,j->ki", sampled, v) + c) @ K.T + B + rng.normal(0, SIGMA, (len(t), 3)))
        Rs.append(stamped)
        ws.append(reference_rate(t, stamped))
        cs.append(c)
    moves = MoveSamples(np.concatenate(ys), np.concatenate(Rs), np.concatenate(ws), np.concatenate(cs),
                        np.full(3, SIGMA), np.repeat(np.arange(n_moves) >= n_moves // 2, len(t)))
    return (y_means.mean(axis=1), y_means.std(axis=1, ddof=1), R, v, H, B, moves)


def h_error(H_est, H):
    return float(np.linalg.norm(H_est - H) / np.linalg.norm(H))


def test_move_samples_reach_their_bound_with_a_sample_time_offset_and_a_known_extra_input():
    """Ten units: the fit with the moves recovers the 8 ms offset, its H error is at the Cramer-Rao bound of the
    holds and moves together, below the holds' alone (which an offset or an extra input left unmodelled would
    not allow: 8 ms at ~2 rad/s is 0.16 m/s^2, 13 sigma)."""
    rng = np.random.default_rng(11)
    holds_err, moves_err, offsets = [], [], []
    for _ in range(10):
        y_means, y_std, R, v, H, B, moves = synthetic(rng, extra_amplitude=0.3)
        counts = np.full(len(R), HOLD_SAMPLES)
        hold_fit = calibrate_joint(y_means, R, NORM, y_std=y_std, counts=counts)
        fit = calibrate_with_moves(hold_fit, y_means, R, np.full((len(R), 3), SIGMA / np.sqrt(HOLD_SAMPLES)), NORM,
                                   moves)
        holds_err.append(h_error(hold_fit.H, H))
        moves_err.append(h_error(fit.H, H))
        offsets.append((fit.extra["time_offset_s"], fit.extra["time_offset_std_s"]))
    for delta, sd in offsets:
        assert abs(delta - OFFSET_S) < max(4 * sd, 2e-5), (delta, sd)
    bound = cramer_rao(np.concatenate([R, moves.R]), H, B, v,
                       np.concatenate([np.full(len(R), SIGMA / np.sqrt(HOLD_SAMPLES)), np.full(len(moves), SIGMA)]))
    holds_bound = cramer_rao(R, H, B, v, SIGMA / np.sqrt(HOLD_SAMPLES))
    rms = lambda e: float(np.sqrt(np.mean(np.square(e))))  # noqa: E731
    assert bound.H_rel_rms < 0.8 * holds_bound.H_rel_rms, (bound.H_rel_rms, holds_bound.H_rel_rms)   # the setup
    assert 0.6 * bound.H_rel_rms < rms(moves_err) < 1.4 * bound.H_rel_rms, (rms(moves_err), bound.H_rel_rms)
    assert rms(moves_err) < holds_bound.H_rel_rms, (rms(moves_err), holds_bound.H_rel_rms)


def test_move_samples_misfit_by_a_noisy_reference_are_weighted_by_their_own_scatter():
    """A reference ten times noisier than the sensor on the move rows: weighted by the sensor's noise they would
    dominate the holds; weighted by their scatter the fit stays at the holds' accuracy or better."""
    rng = np.random.default_rng(5)
    errs, holds = [], []
    for _ in range(6):
        y_means, y_std, R, v, H, B, moves = synthetic(rng)
        tilt = rng.normal(0, 10 * SIGMA / NORM, (len(moves), 3))
        noisy = MoveSamples(moves.y + np.cross(tilt, moves.y - B), moves.R, moves.omega, moves.extra,
                            moves.sigma)
        hold_fit = calibrate_joint(y_means, R, NORM, y_std=y_std, counts=np.full(len(R), HOLD_SAMPLES))
        fit = calibrate_with_moves(hold_fit, y_means, R, np.full((len(R), 3), SIGMA / np.sqrt(HOLD_SAMPLES)), NORM,
                                   noisy)
        assert min(fit.extra["move_sample_sigma"]) > 5 * SIGMA
        errs.append(h_error(fit.H, H))
        holds.append(h_error(hold_fit.H, H))
    assert np.sqrt(np.mean(np.square(errs))) < 1.1 * np.sqrt(np.mean(np.square(holds)))


def test_each_stretch_of_uninterrupted_sampling_has_its_own_time_offset():
    """The chip's phase to the tick grid changed half-way (a resumed run): 8 ms before, 2 ms after, both found."""
    from rig.pipeline.move_rows import stretch_labels

    assert stretch_labels(np.array([0.0, 0.01, 0.02, 1.02, 1.03, 1.08, 1.09])).tolist() == [0, 0, 0, 1, 1, 2, 2]
    rng = np.random.default_rng(2)
    y_means, y_std, R, v, H, B, moves = synthetic(rng, offsets=lambda k: 0.008 if k < 4 else 0.002)
    hold_fit = calibrate_joint(y_means, R, NORM, y_std=y_std, counts=np.full(len(R), HOLD_SAMPLES))
    fit = calibrate_with_moves(hold_fit, y_means, R, np.full((len(R), 3), SIGMA / np.sqrt(HOLD_SAMPLES)), NORM, moves)
    low, high = fit.extra["time_offset_range_s"]
    assert abs(low - 0.002) < 2e-4 and abs(high - 0.008) < 2e-4, (low, high)
    assert h_error(fit.H, H) < 3 * cramer_rao(R, H, B, v, SIGMA / np.sqrt(HOLD_SAMPLES)).H_rel_rms


@pytest.fixture(scope="module")
def stale_session(tmp_path_factory):
    """A session of the second independent simulator whose move reference repeats every tenth row's (the table
    polled at a tenth of the sample rate, held between polls)."""
    from rig.io.session_csv import read_session

    d = tmp_path_factory.mktemp("stale") / "s"
    truth = vs.write_session(vs.generate(vs.config_for("baseline"), 3), d)
    session = read_session(d)
    rows = np.flatnonzero(session.is_move)
    polled = rows - rows % 10
    stale = rows[(polled != rows) & session.is_move[polled]]
    session.q_ref[stale] = session.q_ref[stale - stale % 10]
    moving = np.linalg.norm(session.q_ref[stale] - session.q_ref[stale - 1], axis=1) == 0
    return session, truth, int(moving.sum())


def test_rows_whose_reference_is_stale_are_left_out_and_do_not_spoil_the_fit(stale_session):
    import json

    from rig.pipeline import calibrate_session

    session, truth_path, stale_rows = stale_session
    truth = json.loads(truth_path.read_text())
    with_moves = calibrate_session(session)
    holds_only = calibrate_session(session, move_samples=False)
    for name in ("accel", "mag"):
        extra = with_moves.sensors[name].extra
        assert extra["move_rows_left_out"] >= 0.8 * stale_rows * (0.5 if name == "mag" else 1.0), extra
        assert "move_samples" not in holds_only.sensors[name].extra
        err = {k: h_error(r.sensors[name].H, np.array(truth[name]["H"])) for k, r in (("moves", with_moves),
                                                                                      ("holds", holds_only))}
        assert err["moves"] < 1.3 * err["holds"] + 2e-6, (name, err)


def test_rig_calibrate_from_holds_only_keeps_the_hold_fit(tmp_path):
    """`rig calibrate --from DIR --holds-only`: the accelerometer and magnetometer from the hold means alone (what
    the file says), the default with the move samples too."""
    import json
    import subprocess

    vs.write_session(vs.generate(vs.config_for("orient12"), 1), tmp_path / "s")
    docs = {}
    for label, flags in (("holds", ["--holds-only"]), ("moves", [])):
        res = subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--from", str(tmp_path / "s"), "--out",
                              str(tmp_path / label), *flags], capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr
        docs[label] = json.loads((tmp_path / label / "calibration.json").read_text())
    assert docs["holds"]["source"]["move_samples"] is False and docs["moves"]["source"]["move_samples"] is True
    for name in ("accel", "mag"):
        assert "move_samples" not in docs["holds"]["sensors"][name]
        assert docs["moves"]["sensors"][name]["move_samples"] > 1000
        assert docs["moves"]["sensors"][name]["hold_only"]["H"] == docs["holds"]["sensors"][name]["H"]


def test_a_stretch_too_still_to_fix_its_offset_shares_its_neighbours():
    """A stall at the end of a move starts a stretch of still rows: left with its own offset, the fit let it
    wander beyond any clock (1e11 ms in a fault campaign session) and refused every move sample."""
    rng = np.random.default_rng(4)
    y_means, y_std, R, v, H, B, moves = synthetic(rng)
    label = np.asarray(moves.move, dtype=int).copy()
    n_per_move = len(moves) // 9
    still = np.arange(n_per_move - 3, n_per_move)                # the last rows of the first move: at rest
    label[still] = label.max() + 1
    moves = MoveSamples(moves.y, moves.R, moves.omega, moves.extra, moves.sigma, label)
    hold_fit = calibrate_joint(y_means, R, NORM, y_std=y_std, counts=np.full(len(R), HOLD_SAMPLES))
    fit = calibrate_with_moves(hold_fit, y_means, R, np.full((len(R), 3), SIGMA / np.sqrt(HOLD_SAMPLES)), NORM, moves)
    low, high = fit.extra["time_offset_range_s"]
    assert abs(low - OFFSET_S) < 5e-4 and abs(high - OFFSET_S) < 5e-4, (low, high)
    assert h_error(fit.H, H) < h_error(hold_fit.H, H) * 1.5


def test_move_rows_that_never_turn_are_refused_without_an_absurd_offset():
    """Only still rows (a mixed rig's chips see the table 0.2 s late, so only rows at rest have a reference that
    agrees with the gyro): the offset is free; the fit ran it to -1.6e12 ms and printed that as the reason."""
    import re

    from rig.errors import CalibrationError

    rng = np.random.default_rng(6)
    y_means, y_std, R, v, H, B, moves = synthetic(rng)
    Rs = np.repeat(R, 20, axis=0)                               # 20 rows at rest at every hold's orientation
    y = np.einsum("kji,j->ki", Rs, v) @ np.linalg.inv(H).T + B + rng.normal(0, SIGMA, (len(Rs), 3))
    omega = rng.normal(0, 1e-14, (len(Rs), 3))                  # the reference's rate there: rounding only
    still = MoveSamples(y, Rs, omega, np.zeros_like(y), np.full(3, SIGMA), np.repeat(np.arange(len(R)), 20))
    hold_fit = calibrate_joint(y_means, R, NORM, y_std=y_std, counts=np.full(len(R), HOLD_SAMPLES))
    with pytest.raises(CalibrationError, match="turn too little") as refused:
        calibrate_with_moves(hold_fit, y_means, R, np.full((len(R), 3), SIGMA / np.sqrt(HOLD_SAMPLES)), NORM, still)
    figures = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?", str(refused.value))]
    assert all(abs(x) <= 1000 for x in figures), str(refused.value)
