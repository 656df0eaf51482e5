"""rig.quaternions against scipy's Rotation: the project's convention (scalar first, w >= 0, stacks of any shape) kept."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rig.quaternions import (cube_rotations, matrix_from_quat, matrix_from_rotvec, quat_conjugate, quat_from_matrix,
                             quat_from_rotvec, quat_multiply, rotvec_from_matrix, rotvec_from_quat)
from rig.rotations import axis_angle_matrix

TOL = 1e-14


def _rotvecs(rng: np.random.Generator, n: int = 400) -> np.ndarray:
    """Random axes at angles across (0, pi], with the edges: tiny angles, the series' switch at 1e-3, and pi."""
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, np.pi, n - 40), 10.0 ** rng.uniform(-12, -2, 10),
                             1e-3 * (1 + rng.uniform(-1e-6, 1e-6, 10)), np.pi - 10.0 ** rng.uniform(-12, -3, 10),
                             np.full(10, np.pi)])
    v = axes * angles[:, None]
    v[-5:] = [[np.pi, 0, 0], [0, -np.pi, 0], [0, 0, 0], [1e-300, 0, 0], [0, 0, -np.pi]]
    return v


def test_rotvec_matrix_quat_round_trips_equal_scipy():
    v = _rotvecs(np.random.default_rng(1))
    ref = Rotation.from_rotvec(v)
    assert np.allclose(matrix_from_rotvec(v), ref.as_matrix(), rtol=0, atol=TOL)
    assert np.allclose(quat_from_rotvec(v), ref.as_quat(scalar_first=True), rtol=0, atol=TOL)
    R = ref.as_matrix()
    q_ref = Rotation.from_matrix(R).as_quat(scalar_first=True)
    q_ref = np.where(q_ref[:, :1] < 0, -q_ref, q_ref)
    assert np.allclose(quat_from_matrix(R), q_ref, rtol=0, atol=TOL)
    assert np.allclose(rotvec_from_matrix(R), Rotation.from_matrix(R).as_rotvec(), rtol=0, atol=1e-13)
    q = ref.as_quat(scalar_first=True) * np.random.default_rng(2).uniform(0.5, 2, (len(v), 1))
    q[::3] *= -1
    assert np.allclose(rotvec_from_quat(q), Rotation.from_quat(q, scalar_first=True).as_rotvec(), rtol=0, atol=1e-13)
    assert np.allclose(matrix_from_quat(q), Rotation.from_quat(q, scalar_first=True).as_matrix(), rtol=0, atol=TOL)


def test_single_items_and_shapes():
    v = np.array([0.3, -0.2, 0.5])
    assert matrix_from_rotvec(v).shape == (3, 3)
    assert quat_from_matrix(matrix_from_rotvec(v)).shape == (4,)
    assert rotvec_from_matrix(matrix_from_rotvec(v)).shape == (3,)
    assert np.allclose(rotvec_from_matrix(matrix_from_rotvec(v)), v, atol=TOL)
    stack = np.random.default_rng(3).normal(size=(2, 5, 3))
    assert matrix_from_rotvec(stack).shape == (2, 5, 3, 3)
    ref = Rotation.from_rotvec(stack.reshape(-1, 3)).as_matrix()
    assert np.allclose(matrix_from_rotvec(stack).reshape(-1, 3, 3), ref, atol=TOL)
    assert matrix_from_rotvec(np.zeros((0, 3))).shape == (0, 3, 3)
    assert quat_from_matrix(np.zeros((0, 3, 3))).shape == (0, 4)


def test_axis_angle_and_products():
    rng = np.random.default_rng(4)
    axis, angles = rng.normal(size=3), rng.uniform(-7, 7, 50)
    ref = Rotation.from_rotvec(np.multiply.outer(angles, axis / np.linalg.norm(axis))).as_matrix()
    assert np.allclose(axis_angle_matrix(axis, angles), ref, atol=TOL)
    qa, qb = Rotation.random(50, random_state=5), Rotation.random(50, random_state=6)
    ours = rotvec_from_quat(quat_multiply(quat_conjugate(qa.as_quat(scalar_first=True)), qb.as_quat(scalar_first=True)))
    assert np.allclose(ours, (qa.inv() * qb).as_rotvec(), atol=1e-13)


def test_matrices_not_quite_orthogonal_are_projected_as_scipy_does():
    rng = np.random.default_rng(7)
    R = Rotation.random(60, random_state=8).as_matrix()
    R[:20] += rng.normal(scale=1e-3, size=(20, 3, 3))        # far from orthogonal: projected by the SVD
    R[20:40] += rng.normal(scale=1e-13, size=(20, 3, 3))     # round-off: used as is
    R[40:] *= 1.01                                           # a scaled rotation
    ref = Rotation.from_matrix(R).as_quat(scalar_first=True)
    ref = np.where(ref[:, :1] < 0, -ref, ref)
    assert np.allclose(quat_from_matrix(R), ref, rtol=0, atol=1e-13)


def test_left_handed_or_null_matrices_are_refused():
    for bad in (-np.eye(3), np.zeros((3, 3)), np.diag([1.0, 1.0, -1.0])):
        with pytest.raises(ValueError, match="determinant"):
            quat_from_matrix(bad)
    with pytest.raises(ValueError, match="zero norm"):
        matrix_from_quat(np.zeros(4))


def test_cube_rotations_are_scipys_octahedral_group():
    ours = cube_rotations()
    ref = Rotation.create_group("O").as_matrix()
    assert ours.shape == (24, 3, 3)
    assert np.allclose(ours, ref, rtol=0, atol=1e-15)            # same order, so ties in a search break alike
    assert set(np.unique(ours)) == {-1.0, 0.0, 1.0}
