"""Schedules are checked before the table moves; the right fixture axis is named."""

import numpy as np

from rig.calibration.turntable.observability import check_schedule
from rig.rotations import TableGeometry, rot_x, rot_z

OUTER = np.repeat([0.0, 60, 120, 180, 240, 300], 3)
INNER = np.tile([30.0, 100, 200], 6)


def test_tumble_schedule_is_observable():
    rep = check_schedule(TableGeometry().rotation(OUTER, INNER))
    assert rep.ok and rep.unobservable_axes == [] and rep.message == "schedule observable"
    assert len(rep.singular_values) == 14


def test_vertical_outer_axis_flags_fixture_x():
    R = rot_z(np.radians(OUTER)) @ rot_x(np.radians(INNER))   # conventions.md: gravity never reaches x
    rep = check_schedule(R)
    assert not rep.ok
    assert rep.unobservable_axes == ["x"]
    assert "coplanar" in rep.message and "x" in rep.message
    assert rep.singular_values[-1] < 1e-9 * rep.singular_values[0]


def test_coplanar_directions_about_another_axis_are_named():
    R = rot_x(np.radians(np.linspace(0, 330, 12))) @ rot_z(np.radians(90.0))  # inner fixed at 90 deg
    rep = check_schedule(R)
    assert not rep.ok and rep.unobservable_axes == ["y"]


def test_inner_axis_only_is_a_cone_about_z():
    rep = check_schedule(TableGeometry().rotation(np.full(12, 30.0), np.linspace(0, 330, 12)))
    assert not rep.ok
    assert rep.unobservable_axes == ["z"] and "cone" in rep.message


def test_too_few_orientations():
    rep = check_schedule(TableGeometry().rotation(OUTER[:6], INNER[:6]))
    assert not rep.ok and "6 orientations" in rep.message


def test_magnetometer_reference_changes_the_verdict():
    R = rot_z(np.radians(OUTER)) @ rot_x(np.radians(INNER))
    dip = np.radians(60.0)
    assert check_schedule(R, reference_world=(np.cos(dip), 0.0, -np.sin(dip))).ok


def test_repeated_directions_are_observable_for_joint_only():
    # 4 x 3 grid: outer 0/180 repeat gravity along +-z three times each -> 8 distinct directions
    outer, inner = np.repeat([0.0, 90, 180, 270], 3), np.tile([0.0, 120, 240], 4)
    rep = check_schedule(TableGeometry().rotation(outer, inner))
    assert rep.ok and not rep.two_step_ok
    assert rep.distinct_directions == 8 and "joint method only" in rep.message
    assert check_schedule(TableGeometry().rotation(OUTER, INNER)).two_step_ok
