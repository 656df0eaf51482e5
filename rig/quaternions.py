"""Quaternions, rotation vectors and matrices: conversions and products, scipy's `Rotation` formulas in numpy.

Quaternions are scalar-first `(w, x, y, z)`, Hamilton product, stored with `w >= 0` (conventions.md).
Functions accept a single item or a stack. Markley's matrix -> quaternion, the series near zero angle and
the SVD for a matrix that is not orthogonal are scipy's; scipy.spatial costs ~0.2 s to import, more than a
whole `rig calibrate --from` may take. tests/startup/test_rotations.py holds these
equal to scipy's `Rotation` to round-off.
"""

from __future__ import annotations

import numpy as np


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion(s) with w >= 0; a matrix that is not orthogonal is first replaced by the
    nearest rotation (U V^T of its SVD), one with det <= 0 refused (ValueError), as scipy's from_matrix."""
    q = _xyzw_from_matrix(R)
    q = np.concatenate([q[..., 3:], q[..., :3]], axis=-1)
    return np.where(q[..., :1] < 0, -q, q)


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of scalar-first quaternion(s), normalised first.

    Each entry is a quadratic form in q (scipy's as_matrix), so all nine come from the ten products q_a q_b in
    one matrix product, divided by |q|^2 for the normalisation."""
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"expected quaternions of shape (..., 4), got {q.shape}")
    norm2 = np.einsum("...i,...i->...", q, q)
    if np.any(norm2 == 0):
        raise ValueError("Found zero norm quaternions in `quat`.")
    products = q.take(_PRODUCT_A, axis=-1) * q.take(_PRODUCT_B, axis=-1)
    return ((products @ _QUADRATIC) / norm2[..., None]).reshape(q.shape[:-1] + (3, 3))


_PRODUCT_A, _PRODUCT_B = np.array([0, 1, 2, 3, 0, 0, 0, 1, 1, 2]), np.array([0, 1, 2, 3, 1, 2, 3, 2, 3, 3])


def _quadratic_forms() -> np.ndarray:
    """(10, 9): the coefficient of each product q_a q_b (a <= b; w, x, y, z = 0, 1, 2, 3) in each entry of R."""
    entries = [{(0, 0): 1, (1, 1): 1, (2, 2): -1, (3, 3): -1}, {(1, 2): 2, (0, 3): -2}, {(1, 3): 2, (0, 2): 2},
               {(1, 2): 2, (0, 3): 2}, {(0, 0): 1, (1, 1): -1, (2, 2): 1, (3, 3): -1}, {(2, 3): 2, (0, 1): -2},
               {(1, 3): 2, (0, 2): -2}, {(2, 3): 2, (0, 1): 2}, {(0, 0): 1, (1, 1): -1, (2, 2): -1, (3, 3): 1}]
    rows = {(int(a), int(b)): k for k, (a, b) in enumerate(zip(_PRODUCT_A, _PRODUCT_B))}
    C = np.zeros((10, 9))
    for j, terms in enumerate(entries):
        for ab, c in terms.items():
            C[rows[ab], j] = c
    return C


_QUADRATIC = _quadratic_forms()


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
    q = _normalised(np.asarray(q, dtype=float))
    w, v = q[..., :1], q[..., 1:]
    first = np.take_along_axis(v, np.argmax(v != 0, axis=-1)[..., None], axis=-1)
    flip = (w < 0) | ((w == 0) & (first < 0))
    w, v = np.where(flip, -w, w), np.where(flip, -v, v)
    angle = 2.0 * np.arctan2(np.linalg.norm(v, axis=-1, keepdims=True), w)
    small = angle <= 1e-3
    a2 = angle * angle
    scale = np.where(small, 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0, angle / (np.sin(angle / 2.0) + small))
    return scale * v


def rotvec_from_matrix(R: np.ndarray) -> np.ndarray:
    return rotvec_from_quat(quat_from_matrix(R))


def quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion(s) of rotation vector(s) (w may be negative beyond pi)."""
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"expected rotation vectors of shape (..., 3), got {v.shape}")
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    small = angle <= 1e-3
    a2 = angle * angle
    scale = np.where(small, 0.5 - a2 / 48.0 + a2 * a2 / 3840.0, np.sin(angle / 2.0) / (angle + small))
    return np.concatenate([np.cos(angle / 2.0), v * scale], axis=-1)


def matrix_from_rotvec(v: np.ndarray) -> np.ndarray:
    return matrix_from_quat(quat_from_rotvec(v))


def cube_rotations() -> np.ndarray:
    """The 24 rotations that map the coordinate axes onto +-axes (the octahedral group), (24, 3, 3), exact, in
    the order of scipy's `Rotation.create_group("O")` (ties in a search over them break alike)."""
    half, c = 0.5, np.sqrt(2) / 2
    tetrahedral = [(half, y * half, z * half, w * half) for w in (1, -1) for y in (-1, 1) for z in (-1, 1)]
    octahedral = [(c, 0, 0, c), (0, c, 0, c), (0, 0, c, c), (0, 0, -c, c), (0, -c, 0, c), (-c, 0, 0, c),
                  (0, c, c, 0), (0, -c, c, 0), (c, 0, c, 0), (-c, 0, c, 0), (c, c, 0, 0), (-c, c, 0, 0)]
    xyzw = np.concatenate([np.eye(4), np.array(tetrahedral), np.array(octahedral)])
    return np.round(matrix_from_quat(np.roll(xyzw, 1, axis=-1))) + 0.0


def _normalised(q: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise ValueError("Found zero norm quaternions in `quat`.")
    return q / norm


def _xyzw_from_matrix(R: np.ndarray) -> np.ndarray:
    """scipy's from_matrix: (x, y, z, w), after the det and orthogonality checks.

    Markley's four candidates (one per diagonal entry and one for the trace) are each linear in the entries of
    R and 1, so all sixteen components come from one matrix product; the best conditioned one is kept."""
    R = np.array(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"expected rotation matrices of shape (..., 3, 3), got {R.shape}")
    det = np.linalg.det(R)
    if np.any(det <= 0):
        i = int(np.flatnonzero(np.atleast_1d(det) <= 0)[0])
        raise ValueError(f"Non-positive determinant (left-handed or null coordinate frame) in rotation matrix {i}: "
                         f"{R.reshape(-1, 3, 3)[i]}.")
    gram = R @ np.swapaxes(R, -1, -2)
    skewed = np.any(np.abs(gram - _EYE) > 1e-12 + 1e-5 * _EYE, axis=(-2, -1))    # scipy's isclose(gram, I)
    if np.any(skewed):
        U, _, Vt = np.linalg.svd(R[skewed], full_matrices=False)
        R[skewed] = U @ Vt
    flat = R.reshape(R.shape[:-2] + (9,))
    candidates = (flat @ _MARKLEY[:9] + _MARKLEY[9]).reshape(R.shape[:-2] + (4, 4))
    decision = flat[..., [0, 4, 8, 0]]
    decision[..., 3] = flat[..., 0] + flat[..., 4] + flat[..., 8]
    choice = np.argmax(decision, axis=-1)[..., None, None]
    q = np.take_along_axis(candidates, choice, axis=-2)[..., 0, :]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _markley_candidates() -> np.ndarray:
    """(10, 16): the four (x, y, z, w) candidates of scipy's from_matrix as linear maps of (R.ravel(), 1)."""
    C = np.zeros((10, 4, 4))
    r = lambda i, j: 3 * i + j  # noqa: E731
    for k in range(3):                       # candidate k: component k is 1 - trace + 2 R_kk
        C[9, k, k] = 1.0
        for i in range(3):
            C[r(i, i), k, k] -= 1.0
        C[r(k, k), k, k] += 2.0
        for i in range(3):
            if i != k:
                C[r(i, k), k, i] += 1.0
                C[r(k, i), k, i] += 1.0
        i, j = (k + 1) % 3, (k + 2) % 3      # w = R_ji - R_ij
        C[r(j, i), k, 3] += 1.0
        C[r(i, j), k, 3] -= 1.0
    C[9, 3, 3] = 1.0                         # candidate 3: w = 1 + trace, (x, y, z) from the skew part
    for i in range(3):
        C[r(i, i), 3, 3] += 1.0
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        C[r(j, i), 3, k] += 1.0
        C[r(i, j), 3, k] -= 1.0
    return C.reshape(10, 16)


_MARKLEY = _markley_candidates()
_EYE = np.eye(3)
