"""The motion of a twin's replay (`procedures.twin.replay`): the fixture's attitude at every sample of the recording,
turned onto each pose's gravity direction where the pose begins and carried by the calibrated rate between poses
(`attitudes`), and that attitude evaluated once on the recording's own time grid for every replica to sense
(`ReplayedAttitude`)."""

from __future__ import annotations

import numpy as np

from fixtures.world.recorded import RecordedAttitude
from rig.rotations import matrix_from_rotvec


def attitudes(t: np.ndarray, omega: np.ndarray, pose_of: np.ndarray, up: list[np.ndarray],
               heading: tuple[list[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """R(t) (n, 3, 3): turned the least onto each pose's gravity direction where the pose begins, held through
    it, and between poses carried by the rate, one trapezoid step per sample. The steps' rotations are formed
    at once; only their product runs in order, over the samples where something changes. With `heading` (each
    pose's calibrated field, the world's field) a pose is also turned about the vertical so that its field points
    where the world's does: the magnetometer measured the heading there, which the rate carried across the
    motions misses by up to a degree on a Ferraris session; its replicas' pose fields were up to 0.65 uT
    (twice the noise) off the recording's, which moved the value step of a stream in full precision."""
    n = len(t)
    R = np.empty((n, 3, 3))
    current = align(np.eye(3), up[pose_of[0]] if pose_of[0] >= 0 else unit(np.array([0.0, 0.0, 1.0])))
    entry = (pose_of >= 0) & np.r_[True, pose_of[1:] != pose_of[:-1]]
    moving = np.r_[False, pose_of[1:] < 0]
    i_move = np.flatnonzero(moving)
    steps = iter(matrix_from_rotvec(0.5 * (omega[i_move - 1] + omega[i_move]) * (t[i_move] - t[i_move - 1])[:, None]))
    changes = np.flatnonzero(entry | moving)
    ends = np.r_[changes[1:], n]
    R[:changes[0] if changes.size else n] = current
    for i, end in zip(changes, ends):         # the moving rows among the changes are i_move, in order
        current = align(current, up[pose_of[i]]) if entry[i] else current @ next(steps)
        if heading is not None and entry[i]:
            current = head(current, heading[0][pose_of[i]], heading[1])
        R[i:end] = current
    return R


class ReplayedAttitude:
    """The replayed attitude evaluated once on the recording's own time grid, which every replica senses (each
    sensor of each replica: 360 evaluations of 51 175 attitudes for the Xsens, a tenth of its analysis); other
    times (a stream delayed by an effect) are interpolated as before. On the grid, callers get read-only views, not
    copies: nothing they do reaches the next replica, and a replica of a 6-hour log does not hold 207 MiB more per
    sensor (an attempt to write raises). The rate on the grid is the recorded rate itself, which the
    interpolation gives back there."""

    def __init__(self, recorded: RecordedAttitude, t: np.ndarray) -> None:
        self.recorded = recorded
        self.t = np.asarray(t, dtype=float)
        self._R_on_grid = recorded.attitude(self.t)[0]

    def attitude(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.shape == self.t.shape and np.array_equal(t, self.t):
            return _read_only(self._R_on_grid), _read_only(self.recorded.omega)
        return self.recorded.attitude(t)


def _read_only(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


def align(R: np.ndarray, u: np.ndarray) -> np.ndarray:
    """R turned the least (in the fixture) so that world up, seen in the fixture, is u: R^T z = u."""
    v = R.T @ np.array([0.0, 0.0, 1.0])
    axis = np.cross(u, v)
    s, c = np.linalg.norm(axis), float(np.clip(u @ v, -1.0, 1.0))
    if s < 1e-12:
        return R if c > 0 else R @ matrix_from_rotvec(np.pi * unit(np.cross(v, [1.0, 0.0, 0.0])
                                                                    if abs(v[0]) < 0.9 else np.cross(v, [0, 1.0, 0])))
    return R @ matrix_from_rotvec(axis / s * np.arctan2(s, c))


def head(R: np.ndarray, m: np.ndarray, m_world: np.ndarray) -> np.ndarray:
    """R turned about world up so that the field m, seen in the fixture, points horizontally where m_world does."""
    a = R @ m
    if not (np.isfinite(a).all() and np.isfinite(m_world).all()):      # a pose without a field sample keeps its heading
        return R
    psi = np.arctan2(m_world[1], m_world[0]) - np.arctan2(a[1], a[0])
    return matrix_from_rotvec(np.array([0.0, 0.0, psi])) @ R


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)
