"""Where the gyro fits start: a first H that already knows how the board is mounted.

The UKF and the trust-region fit of gyro.py refine H locally; from `s I` they reach the right basin only when
the sensor axes are within ~60 deg of the fixture axes. A board mounted turned 90 deg, with permuted axes or
upside down is common, so the start has to carry the mounting. Two linear estimates, both from
`phi ~ H * integral(y - B) dt`, which holds for rotations small enough to turn about a nearly fixed axis:

* reference stretches: the moves cut into ~0.1 s pieces, `phi` from the reference orientation at the piece's
  ends (turns of a few degrees: no wrap at pi, axis nearly fixed). Needs the reference inside the moves.
* whole moves: `phi` the known rotation of each move (rotation vector of R_j^T R_{j+1}); rougher, for data that
  carries only the hold orientations.

The candidates (these and `s I`) are compared on the rotation misfit over all moves and the best is kept.
"""

from __future__ import annotations

import numpy as np
from rig.quaternions import quat_conjugate, quat_multiply, rotvec_from_matrix, rotvec_from_quat
from rig.session_data import MoveStream

STRETCH_S = 0.1
MIN_SPREAD = 0.05      # smallest / largest singular value of the stacked raw integrals


def linear_start(raw_integrals: np.ndarray, phi: np.ndarray) -> np.ndarray | None:
    """H minimising sum |phi_k - H s_k|^2, or None when the s_k do not span three axes."""
    S, P = np.asarray(raw_integrals, dtype=float), np.asarray(phi, dtype=float)
    if len(S) < 3:
        return None
    sv = np.linalg.svd(S, compute_uv=False)
    if not sv[0] > 0 or sv[-1] < MIN_SPREAD * sv[0]:
        return None
    Ht, *_ = np.linalg.lstsq(S, P, rcond=None)
    H = Ht.T
    return H if np.all(np.isfinite(H)) and abs(np.linalg.det(H)) > 0 else None


def _integral(m: MoveStream, B: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of the raw rate minus bias, (len(t), 3), counts * s."""
    z = m.y - B
    inc = 0.5 * (z[1:] + z[:-1]) * np.diff(m.t)[:, None]
    return np.vstack([np.zeros(3), np.cumsum(inc, axis=0)])


def reference_stretches(moves: list[MoveStream], B: np.ndarray, stretch_s: float = STRETCH_S):
    """(raw integrals, reference rotation vectors) over ~stretch_s pieces of every move with a reference."""
    S, qa, qb = [], [], []
    for m in moves:
        if m.q_ref is None or len(m.t) < 3:
            continue
        cut = np.unique(np.r_[np.searchsorted(m.t, np.arange(m.t[0], m.t[-1], stretch_s)), len(m.t) - 1].clip(max=len(m.t) - 1))
        if len(cut) < 2:
            continue
        c = _integral(m, B)
        S.append(c[cut[1:]] - c[cut[:-1]])
        qa.append(m.q_ref[cut[:-1]])
        qb.append(m.q_ref[cut[1:]])
    if not S:
        return np.empty((0, 3)), np.empty((0, 3))
    qa, qb = (np.vstack(q) / np.linalg.norm(np.vstack(q), axis=1, keepdims=True) for q in (qa, qb))
    return np.vstack(S), rotvec_from_quat(quat_multiply(quat_conjugate(qa), qb))


def whole_moves(moves: list[MoveStream], B: np.ndarray):
    """(raw integral, known rotation vector) of each move."""
    S = np.array([_integral(m, B)[-1] for m in moves])
    phi = rotvec_from_matrix(np.array([m.known_rotation for m in moves]))
    return S, phi


def start_candidates(moves: list[MoveStream], B: np.ndarray) -> list[np.ndarray]:
    """The linear starts that exist for these moves (reference stretches first)."""
    out = []
    for S, phi in (reference_stretches(moves, B), whole_moves(moves, B)):
        H = linear_start(S, phi)
        if H is not None:
            out.append(H)
    return out
