"""Quaternions, rotation vectors and matrices in the project's convention, by scipy's `Rotation`.

Quaternions are scalar-first `(w, x, y, z)`, Hamilton product, stored with `w >= 0` (docs/reference/conventions.md).
Functions accept a single item or a stack of any shape; the conversions are scipy's (`Rotation`, imported where
first used: scipy.spatial takes most of a second to import, which commands that only read and write files, such as
`rig import`, would pay for nothing), the product and the conjugate are the textbook formulas on arrays.
"""

from __future__ import annotations

import numpy as np


def _scipy_rotation():
    from scipy.spatial.transform import Rotation
    return Rotation


def _stacked(x: np.ndarray, width: int, what: str) -> tuple[np.ndarray, tuple[int, ...]]:
    """x as a 2-D stack of `width`-vectors for Rotation, and the leading shape to give back."""
    x = np.asarray(x, dtype=float)
    if x.shape[-1:] != (width,):
        raise ValueError(f"expected {what} of shape (..., {width}), got {x.shape}")
    return x.reshape(-1, width), x.shape[:-1]


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion(s) with w >= 0; a matrix that is not orthogonal is first replaced by the
    nearest rotation, one with det <= 0 refused (ValueError), as scipy's from_matrix."""
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"expected rotation matrices of shape (..., 3, 3), got {R.shape}")
    q = _scipy_rotation().from_matrix(R.reshape(-1, 3, 3)).as_quat(scalar_first=True).reshape(R.shape[:-2] + (4,))
    return np.where(q[..., :1] < 0, -q, q)


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of scalar-first quaternion(s), normalised first."""
    flat, lead = _stacked(q, 4, "quaternions")
    return _scipy_rotation().from_quat(flat, scalar_first=True).as_matrix().reshape(lead + (3, 3))

def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product p * q for scalar-first quaternions."""
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    w1, x1, y1, z1 = np.moveaxis(p, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(q, -1, 0)
    return np.stack([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ], -1)


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """The inverse rotation of scalar-first unit quaternion(s)."""
    return np.asarray(q, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])


def rotvec_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation vector(s), angle in [0, pi], of scalar-first quaternion(s), normalised first."""
    flat, lead = _stacked(q, 4, "quaternions")
    return _scipy_rotation().from_quat(flat, scalar_first=True).as_rotvec().reshape(lead + (3,))


def rotvec_from_matrix(R: np.ndarray) -> np.ndarray:
    return rotvec_from_quat(quat_from_matrix(R))


def quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion(s) of rotation vector(s) (w may be negative beyond pi)."""
    flat, lead = _stacked(v, 3, "rotation vectors")
    return _scipy_rotation().from_rotvec(flat).as_quat(canonical=False, scalar_first=True).reshape(lead + (4,))


def matrix_from_rotvec(v: np.ndarray) -> np.ndarray:
    flat, lead = _stacked(v, 3, "rotation vectors")
    return _scipy_rotation().from_rotvec(flat).as_matrix().reshape(lead + (3, 3))


def cube_rotations() -> np.ndarray:
    """The 24 rotations that map the coordinate axes onto +-axes (the octahedral group), (24, 3, 3), exact, in
    the order of scipy's `Rotation.create_group("O")` (ties in a search over them break alike)."""
    return np.round(_scipy_rotation().create_group("O").as_matrix()) + 0.0
