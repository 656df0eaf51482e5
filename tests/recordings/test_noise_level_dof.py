"""How precisely a twin's white noise level is known (`procedures.twin.draws.level_dof`): the replicas draw their
level from it, the plain twin's and the extension's alike, so it must be the scatter the recording's own estimate
has, the quiet poses' selection included."""

from __future__ import annotations

import numpy as np

from procedures.twin.draws import level_dof
from procedures.twin.noise import quiet_spread
from rig.calibration.recordings.recording import RecordingCalibration
from rig.calibration.recordings.segments import Pose
from rig.io.recording import recording_session

LENGTHS = (150, 300, 500, 800, 1200, 400)


def _hand_session(seed: int, held: float) -> tuple:
    """Six poses of the lengths above, white accelerometer noise of 1 in every one; the third and fifth shaken by
    a hand to `held` times that (a quiet pose pool without them)."""
    rng = np.random.default_rng(seed)
    sizes = np.array([1.0, 1.0, held, 1.0, held, 1.0])
    y = np.concatenate([rng.normal(0.0, s, (n, 3)) for n, s in zip(LENGTHS, sizes)])
    edges = np.r_[0, np.cumsum(LENGTHS)]
    session = recording_session(np.arange(len(y)) / 100.0, {"accel": y}, units={"accel": "m/s^2"}, source="synthetic")
    poses = [Pose(f"p{k}", np.arange(a, b), None, 2.0) for k, (a, b) in enumerate(zip(edges[:-1], edges[1:]))]
    return session, RecordingCalibration({}, poses, [], [])


def test_the_quiet_level_scatters_as_its_degrees_of_freedom_say():
    for held in (1.0, 1.6):
        variances, dofs = [], []
        for seed in range(400):
            session, rec = _hand_session(seed, held)
            variances.append(quiet_spread(session, rec, "accel") ** 2)
            dofs.append(level_dof(session, rec, "accel", quiet=True))
        variances, dofs = np.array(variances), np.array(dofs)
        predicted = np.sqrt(2.0 / np.mean(dofs, axis=0))
        seen = variances.std(axis=0) / variances.mean(axis=0)
        assert np.all(np.abs(seen / predicted - 1.0) < 0.2), (held, seen, predicted)
        if held > 1.0:                          # the shaken poses are no part of the level, nor of its dof
            assert np.all(np.mean(dofs, axis=0) < sum(LENGTHS) - len(LENGTHS) - 1500), dofs.mean(axis=0)
