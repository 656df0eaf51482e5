"""Rotations, quaternions and the two-axis table geometry of `docs/reference/conventions.md`.

Quaternions are scalar-first `(w, x, y, z)`, Hamilton product, fixture -> world, stored with `w >= 0`.
Matrices `R` map fixture vectors to world vectors. Functions accept a single item or a stack. The
conversions between quaternions, rotation vectors and matrices live in rig.quaternions (numpy, without
scipy's import cost) and are offered here too, where the project has always imported them from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.quaternions import (cube_rotations, matrix_from_quat, matrix_from_rotvec, quat_conjugate,  # noqa: F401
                             quat_from_matrix, quat_from_rotvec, quat_multiply, rotvec_from_matrix, rotvec_from_quat)


def rot_x(angle_rad: float | np.ndarray) -> np.ndarray:
    """Rotation about x by `angle_rad` (right hand); shape (3, 3) or (n, 3, 3)."""
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle_rad: float | np.ndarray) -> np.ndarray:
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle_rad: float | np.ndarray) -> np.ndarray:
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def axis_angle_matrix(axis: np.ndarray, angle_rad: float | np.ndarray) -> np.ndarray:
    """Rotation by `angle_rad` about the unit vector `axis`."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    a = np.asarray(angle_rad, dtype=float)
    return matrix_from_rotvec(np.multiply.outer(a, axis))


def skew(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


@dataclass(frozen=True)
class TableGeometry:
    """Two-axis table: fixture -> world rotation from encoder angles.

    Default is the tumble configuration of conventions.md: outer axis along world x, inner axis
    along fixture z, `R = Rx(outer) @ Rz(inner)`. Real tables differ, so the axes and zero offsets
    are configuration.
    """

    outer_axis_world: tuple[float, float, float] = (1.0, 0.0, 0.0)
    inner_axis_fixture: tuple[float, float, float] = (0.0, 0.0, 1.0)
    outer_zero_deg: float = 0.0
    inner_zero_deg: float = 0.0
    # Tilt of the inner axis away from orthogonality to the outer one (a rotation applied between
    # the two gimbals), as a rotation vector in degrees; zero for an ideal table.
    inner_tilt_deg: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0))

    def rotation(self, outer_deg: float | np.ndarray, inner_deg: float | np.ndarray) -> np.ndarray:
        """Fixture -> world matrix (or stack) for the given encoder angles in degrees."""
        a = np.radians(np.asarray(outer_deg, dtype=float) + self.outer_zero_deg)
        b = np.radians(np.asarray(inner_deg, dtype=float) + self.inner_zero_deg)
        R_outer = _axis_rotation(self.outer_axis_world, a)
        R_inner = _axis_rotation(self.inner_axis_fixture, b)
        if any(self.inner_tilt_deg):
            return R_outer @ matrix_from_rotvec(np.radians(self.inner_tilt_deg)) @ R_inner
        return R_outer @ R_inner

    def body_rate(self, outer_deg, inner_deg, outer_rate_dps, inner_rate_dps) -> np.ndarray:
        """Angular rate of the fixture in the fixture frame, rad/s, for angles and rates in deg, deg/s.

        With R = Ro(a) T Ri(b): omega_fixture = Ri(b)^T T^T (adot e_o) + bdot e_i.
        """
        b = np.radians(np.asarray(inner_deg, dtype=float) + self.inner_zero_deg)
        e_o = np.asarray(self.outer_axis_world, dtype=float)
        e_i = np.asarray(self.inner_axis_fixture, dtype=float)
        R_inner = _axis_rotation(e_i, b)
        w_o = np.multiply.outer(np.radians(np.asarray(outer_rate_dps, dtype=float)), e_o)
        if any(self.inner_tilt_deg):
            w_o = w_o @ matrix_from_rotvec(np.radians(self.inner_tilt_deg))  # T^T w as row-vector form
        w_o_fixture = np.einsum("...ji,...j->...i", R_inner, w_o)
        return w_o_fixture + np.multiply.outer(np.radians(np.asarray(inner_rate_dps, dtype=float)), e_i)

    def to_dict(self) -> dict:
        return {"outer_axis_world": list(self.outer_axis_world), "inner_axis_fixture": list(self.inner_axis_fixture),
                "outer_zero_deg": self.outer_zero_deg, "inner_zero_deg": self.inner_zero_deg,
                "inner_tilt_deg": list(self.inner_tilt_deg)}


def _axis_rotation(axis, angle_rad: np.ndarray) -> np.ndarray:
    axis = tuple(float(v) for v in axis)
    if axis == (1.0, 0.0, 0.0):
        return rot_x(angle_rad)
    if axis == (0.0, 1.0, 0.0):
        return rot_y(angle_rad)
    if axis == (0.0, 0.0, 1.0):
        return rot_z(angle_rad)
    return axis_angle_matrix(np.array(axis), angle_rad)
