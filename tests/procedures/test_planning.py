"""The planned schedule: every axis excited, the second table pose where it pays, the table's limits kept."""

import numpy as np
import pytest

from rig.schedule import Orientation, plan_orientations, schedule_rotations
from rig.calibration.turntable.bounds import cramer_rao

G = 9.80665
FIELD = 50.0 * np.array([np.cos(np.radians(64)) * np.sin(np.radians(12)),
                         np.cos(np.radians(64)) * np.cos(np.radians(12)), -np.sin(np.radians(64))])


def _one_pose_each(schedule):
    """The same reference directions, every one in the pose with the outer angle in [0, 180]."""
    return [o if o.outer_deg >= 0 else Orientation(-o.outer_deg, (o.inner_deg + 360.0) % 360.0 - 180.0)
            for o in schedule]


def _gravity_directions(schedule):
    return np.einsum("kji,j->ki", schedule_rotations(schedule), [0.0, 0.0, 1.0])


@pytest.mark.parametrize("n", [12, 20])
def test_second_pose_lowers_the_bound_of_accel_and_mag_H(n):
    plan = plan_orientations(n)
    single = _one_pose_each(plan)
    np.testing.assert_allclose(np.sort(_gravity_directions(plan), axis=0),
                               np.sort(_gravity_directions(single), axis=0), atol=1e-9)
    H = np.eye(3) / 400.0
    for v, at_most in (([0.0, 0.0, G], 0.7), (FIELD, 0.85)):
        ours = cramer_rao(schedule_rotations(plan), H, np.zeros(3), np.asarray(v), 1.0).H_rel_rms
        one_pose = cramer_rao(schedule_rotations(single), H, np.zeros(3), np.asarray(v), 1.0).H_rel_rms
        assert ours < at_most * one_pose


def test_a_table_limited_to_positive_outer_angles_keeps_the_first_pose():
    plan = plan_orientations(20, outer_limits=(0.0, 180.0))
    assert all(0.0 <= o.outer_deg <= 180.0 for o in plan)
    assert len({(round(o.outer_deg, 3), round(o.inner_deg, 3)) for o in plan}) == 20
