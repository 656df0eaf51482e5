"""Can a hold schedule calibrate an accelerometer/magnetometer? Checked BEFORE the table moves.

The vector model `y_k = H^-1 R_k^T v + B` (see joint.py) only determines H and B if the reference
directions seen in the fixture frame, `x_k = R_k^T v`, fill 3-D space: if they all lie in a plane through
the origin one column of H^-1 never multiplies anything (e.g. a vertical outer axis: gravity never reaches
fixture x, conventions.md); if they lie on a plane off the origin (a cone, e.g. only the inner axis turns)
the offset along the plane normal is confounded with the scale. Also hosts the input checks shared by
the solvers, so every solver refuses the same bad input with the same message.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.numerics.ellipsoid import SPREAD_RATIO_MIN, later_pairs, refuse_coplanar
from rig.errors import CalibrationError
from rig.rotations import rotvec_from_matrix

AXES = ("x", "y", "z")
INFO_RATIO_MIN = 1e-6
SATURATION_MARGIN = 0.98
DISTINCT_DEG = 2.0
ELLIPSOID_MIN_DIRECTIONS = 9
_I3 = np.eye(3)


@dataclass
class ObservabilityReport:
    ok: bool
    unobservable_axes: list[str]
    singular_values: np.ndarray       # of the joint model's Jacobian (information matrix = J^T J), descending
    message: str
    direction_singular_values: np.ndarray = field(default_factory=lambda: np.zeros(3))
    n_orientations: int = 0
    distinct_directions: int = 0      # reference directions more than DISTINCT_DEG apart
    two_step_ok: bool = False         # the ellipsoid of the two-step method needs >= 9 distinct directions


def check_schedule(R: np.ndarray, *, reference_world=(0.0, 0.0, 1.0),
                   min_orientations: int = 9) -> ObservabilityReport:
    """Observability of B and H from holds at fixture -> world rotations R (n, 3, 3).

    Three tests: enough orientations; the directions R_k^T v are not coplanar through the origin (names the
    fixture axis that never sees the reference) nor on a plane off the origin (offset/scale confounded);
    the joint model's Jacobian at a nominal point has full column rank (14 = 3 B + 9 H + 2 direction).
    """
    R = _as_rotations(R)
    v = np.asarray(reference_world, dtype=float)
    v = v / np.linalg.norm(v)
    n = len(R)
    x = np.einsum("kji,j->ki", R, v)
    problems: list[str] = []
    if n < min_orientations:
        problems.append(f"{n} orientations, need at least {min_orientations}")
    s_dir, dir_problems, axes = direction_problems(x)
    problems += dir_problems
    J = joint_jacobian_nominal(R, v)
    _, s_info, Vt = np.linalg.svd(J, full_matrices=True)
    if len(s_info) < 14 or s_info[-1] < INFO_RATIO_MIN * s_info[0]:
        axis = axis_name(np.sqrt((Vt[-1, 3:12].reshape(3, 3) ** 2).sum(axis=0)))
        if not axes:
            axes.append(axis)
        rank = int(np.sum(s_info > INFO_RATIO_MIN * s_info[0]))
        problems.append(f"the joint model's information matrix is rank deficient ({rank} of 14); "
                        f"weakest along fixture {axis}")
    ok = not problems
    distinct = count_distinct(x)
    two_step_ok = ok and distinct >= ELLIPSOID_MIN_DIRECTIONS
    message = "schedule observable" if ok else "; ".join(problems)
    if ok and not two_step_ok:
        message += (f" for the joint method only: the two-step ellipsoid needs >= {ELLIPSOID_MIN_DIRECTIONS} "
                    f"distinct reference directions, this schedule has {distinct}")
    return ObservabilityReport(ok=ok, unobservable_axes=axes, singular_values=s_info, message=message,
                               direction_singular_values=s_dir, n_orientations=n, distinct_directions=distinct,
                               two_step_ok=two_step_ok)


def direction_problems(x: np.ndarray) -> tuple[np.ndarray, list[str], list[str]]:
    """Spread of the fixture-frame reference directions x (n, 3): (singular values, problems, axes named)."""
    n = max(len(x), 1)
    U, s_dir, _ = np.linalg.svd(x.T @ x / n)
    s_dir = np.sqrt(s_dir)
    if s_dir[-1] < SPREAD_RATIO_MIN * s_dir[0]:
        axis = axis_name(U[:, -1])
        return s_dir, [f"the reference directions are coplanar: fixture axis {axis} never sees the reference "
                       "(e.g. a vertical outer axis); H is unobservable along it"], [axis]
    xc = x - x.mean(axis=0)
    Uc, s_c, _ = np.linalg.svd(xc.T @ xc / n)
    if np.sqrt(s_c[-1]) < SPREAD_RATIO_MIN * s_dir[0]:
        axis = axis_name(Uc[:, -1])
        return s_dir, [f"the reference directions lie on a cone about fixture {axis}: the offset along {axis} is "
                       "confounded with the scale (add tilts of the inner axis)"], [axis]
    return s_dir, [], []


def count_distinct(x: np.ndarray, min_angle_deg: float = DISTINCT_DEG, *, unit: bool = False) -> int:
    """Number of directions not within `min_angle_deg` of an earlier one (repeats add no ellipsoid shape).

    unit=True: the rows of x are unit vectors already."""
    u = x if unit else x / np.sqrt(np.einsum("ij,ij->i", x, x))[:, None]
    close = (u @ u.T > np.cos(np.radians(min_angle_deg))) & later_pairs(len(u))
    return len(u) - int(np.count_nonzero(close.any(axis=0)))


def axis_name(direction: np.ndarray) -> str:
    """'x'/'y'/'z' if `direction` is within ~25 deg of a fixture axis, else the rounded unit vector."""
    d = np.abs(np.asarray(direction, dtype=float))
    d = d / np.linalg.norm(d)
    i = int(np.argmax(d))
    return AXES[i] if d[i] > 0.9 else "(" + ", ".join(f"{c:.2f}" for c in direction / np.linalg.norm(direction)) + ")"


def joint_jacobian_nominal(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Jacobian of `y_k = H^-1 R_k^T v + B` at H = I, B = 0, unit v, w.r.t. (B, vec H, 2 tilts of v): (3n, 14)."""
    n = len(R)
    x = np.einsum("kji,j->ki", R, v)
    J = np.zeros((n, 3, 14))
    J[:, :, 0:3] = np.eye(3)
    J[:, :, 3:12] = -np.einsum("ca,kb->kcab", np.eye(3), x).reshape(n, 3, 9)
    for col, e in zip((12, 13), tangent_basis(v).T):
        J[:, :, col] = np.einsum("kji,j->ki", R, np.cross(e, v))
    return J.reshape(3 * n, 14)


def tangent_basis(v: np.ndarray) -> np.ndarray:
    """(3, 2) orthonormal columns perpendicular to v."""
    v = v / np.linalg.norm(v)
    e1 = np.cross(v, [1.0, 0.0, 0.0] if abs(v[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(v, e1)])


def validate_holds(y_means: np.ndarray, R: np.ndarray | None = None, *, min_orientations: int = 9,
                   full_scale: float | None = None, what: str = "calibration") -> tuple[np.ndarray, np.ndarray | None]:
    """Shared input checks: shapes, NaN rows, saturated axes, proper rotations, count. Returns float arrays."""
    y = np.asarray(y_means, dtype=float)
    if y.ndim != 2 or y.shape[1] != 3:
        raise CalibrationError(f"{what}: y_means must have shape (n, 3), got {y.shape}")
    if not np.isfinite(y).all():
        bad = np.flatnonzero(~np.isfinite(y).all(axis=1))
        raise CalibrationError(f"{what}: hold(s) {bad.tolist()} contain NaN/inf raw means; drop or re-measure them")
    if full_scale is not None:
        sat = np.argwhere(np.abs(y) >= SATURATION_MARGIN * float(full_scale))
        if sat.size:
            k, a = sat[0]
            raise CalibrationError(f"{what}: hold {int(k)} axis {AXES[a]} is saturated (|y| = {abs(y[k, a]):.0f} counts "
                                   f">= {SATURATION_MARGIN:.0%} of full scale {full_scale:g}); "
                                   f"{len(sat)} saturated value(s) in all; choose a larger range")
    if len(y) < min_orientations:
        raise CalibrationError(f"{what}: {len(y)} orientations, need at least {min_orientations}")
    if R is None:
        return y, None
    R = _as_rotations(R, what)
    if len(R) != len(y):
        raise CalibrationError(f"{what}: {len(y)} raw means but {len(R)} rotations")
    return y, R


def require_spread(y: np.ndarray, what: str) -> None:
    """Raw points on a plane (affinely) cannot fix an ellipsoid: refuse rather than return a wrong H."""
    yc = y - y.mean(axis=0)
    refuse_coplanar(yc.T @ yc, what)


def _as_rotations(R: np.ndarray, what: str = "schedule") -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise CalibrationError(f"{what}: rotations must have shape (n, 3, 3), got {R.shape}")
    err = np.abs(R.transpose(0, 2, 1) @ R - _I3)
    if not err.max() <= 1e-6 or np.linalg.det(R).min() < 0:        # NaN fails the first test too
        finite = np.isfinite(R).all(axis=(1, 2))
        if not finite.all():
            raise CalibrationError(f"{what}: rotation(s) {np.flatnonzero(~finite).tolist()} contain NaN/inf")
        bad = np.flatnonzero((err.max(axis=(1, 2)) > 1e-6) | (np.linalg.det(R) < 0))
        raise CalibrationError(f"{what}: rotation(s) {bad.tolist()} are not proper rotations (R^T R != I or det < 0)")
    return R


MOVE_SPREAD_RATIO_MIN = 0.05


def move_axes_problem(known_rotations: np.ndarray) -> str | None:
    """Why the gyro's H is unobservable from these moves, or None.

    The known rotations (k, 3, 3) must turn the fixture about three independent axes: the smallest singular
    value of their stacked rotation vectors, relative to the largest, must not vanish.
    """
    phi = rotvec_from_matrix(np.asarray(known_rotations, dtype=float).reshape(-1, 3, 3))
    if len(phi) < 3:
        return f"only {len(phi)} moves; at least 3 turning about independent axes are needed"
    _, s, vt = np.linalg.svd(phi)
    if s[0] == 0 or s[-1] < MOVE_SPREAD_RATIO_MIN * s[0]:
        axis = np.round(vt[-1], 2).tolist()
        return (f"the moves never rotate about fixture direction {axis} (rotation-vector spread ratio "
                f"{s[-1] / s[0] if s[0] else 0:.3g}); the gyro's H is unobservable along it")
    return None
