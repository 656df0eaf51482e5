"""The `Int` operator of the gyroscope step (Zhang 2015, eqs. 52-55): body rates -> rotation over a move.

Equation numbers follow the project brief; the paper's text was not available here, so the schemes are
ours. Two of them:
- `interval_terms` (the gyro calibration): the rotation vector of each sample interval for either meaning
  of a sample, the rate at its time stamp ("point": cubic through four samples, Magnus order 4 at two
  Gauss points, fourth order in h) or its mean over the sample period ("mean": rectangle plus the
  two-sample coning correction). Reading one kind as the other is a second-order error that dominates.
- `interval_rotvecs` (integrate_quaternion, the attitude filter): the rate linear between two samples,

      phi_k = h (w_k + w_{k+1}) / 2 + h^2 / 12 (w_k x w_{k+1}),

  Magnus order 4 for rates that really are linear between samples (a few 1e-9 rad over 1 s of table-like
  rates at 100 Hz against an ODE solver on the same piecewise-linear rate); second order in h when the
  rate axis turns, because the rotated trapezoid errors do not telescope.

The interval quaternions are multiplied in a balanced tree (log2(m) vectorised levels), which lets one
call integrate a whole stack of rate histories, e.g. all sigma points of the UKF at once.

Convention (conventions.md): rates are in the fixture frame, so the orientation evolves as
`R' = R [w x]` and the result is the body rotation over the interval, `R(t0)^T R(t_end)`.
"""

from __future__ import annotations

import numpy as np

from rig.rotations import matrix_from_quat


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis; np.cross costs ~50 us of overhead per call on small arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def interval_rotvecs(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., m-1, 3) of each sample interval (Magnus order 4, linear rates)."""
    h = np.diff(np.asarray(t, dtype=float))[:, None]
    w0, w1 = omega[..., :-1, :], omega[..., 1:, :]
    return 0.5 * h * (w0 + w1) + (h * h / 12.0) * cross(w0, w1)


SAMPLE_MODELS = ("point", "mean")
# A cubic through samples around a hole (samples lost to a retried bus or table request) swings through the
# hole: 0.05 s missed as a move begins cost 5 mrad. Where the four nodes' spacings differ by more than this
# factor the interval is integrated with the linear rate instead, the least it can assume about the hole.
UNEVEN_SPACING = 1.5
_GAUSS = np.array([0.5 - np.sqrt(3.0) / 6.0, 0.5 + np.sqrt(3.0) / 6.0])   # two-point Gauss nodes on [0, 1]


def interval_terms(t: np.ndarray, u: np.ndarray, samples: str = "point",
                   lengths: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The two parts of each interval's rotation vector, `phi_k = S_k + C_k` (shapes (m-1, 3)).

    S is linear in the samples and C is a cross product of two linear combinations of them, so for
    `w = H u` the rotation vector is `S H^T + C cof(H)^T` (gyro.MoveSet). What a sample means decides the
    scheme; a wrong reading costs far more than the order of the scheme:
    - "point": the rate at t_k. The rate at the two Gauss points of [t_k, t_k+1] comes from the cubic through
      the four nearest samples, then Magnus order 4, `phi = h/2 (a1 + a2) + sqrt(3)/12 h^2 (a1 x a2)`. The
      linear rate between samples is only second order in h for a turning rate axis (its trapezoid error
      does not telescope once rotated); the cubic is fourth order, 150x closer at 50 Hz on smooth moves. Next
      to a hole in the samples (UNEVEN_SPACING) and in streams of fewer than 4 samples the rate is linear.
    - "mean": the mean rate over (t_k-1, t_k], what a decimating or integrating chip reports. Rectangle
      plus the two-sample coning correction, `phi_k = d_k + (d_k-1 x d_k) / 12` with `d_k = h_k u_k`.
    lengths: t and u hold several streams one after the other, of these lengths (each >= 2); the result then
    holds their intervals in the same order (sum(lengths) - len(lengths) rows), none across two streams.
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    lengths = np.array([len(t)]) if lengths is None else np.asarray(lengths, dtype=int)
    lo = np.repeat(np.cumsum(lengths) - lengths, lengths - 1)      # first sample of each interval's stream
    hi = lo + np.repeat(lengths, lengths - 1)                       # one past its last
    k = np.arange(len(lo)) + np.repeat(np.arange(len(lengths)), lengths - 1)   # the interval's first sample
    h = (t[k + 1] - t[k])[:, None]
    if samples == "mean":
        d = h * u[k + 1]
        C = np.zeros_like(d)
        inner = np.flatnonzero(k[1:] > lo[1:]) + 1
        C[inner] = cross(d[inner - 1], d[inner]) / 12.0
        return d, C
    if samples != "point":
        raise ValueError(f"integrate: unknown sample model {samples!r}; expected one of {SAMPLE_MODELS}")
    short = hi - lo < 4
    nodes = np.clip(k - 1, lo, np.maximum(hi - 4, lo))[:, None] + np.arange(4)
    nodes[short] = k[short, None] + np.array([0, 1, 1, 1])          # placeholders, replaced below
    spacing = np.diff(t[nodes], axis=1)
    short |= spacing.max(axis=1) > UNEVEN_SPACING * spacing.min(axis=1)
    a1, a2 = (np.einsum("mj,mjc->mc", _lagrange(t[nodes], t[k] + g * h[:, 0], short), u[nodes]) for g in _GAUSS)
    S, C = 0.5 * h * (a1 + a2), (np.sqrt(3.0) / 12.0) * (h * h) * cross(a1, a2)
    if short.any():
        w0, w1, hs = u[k[short]], u[k[short] + 1], h[short]
        S[short], C[short] = 0.5 * hs * (w0 + w1), (hs * hs / 12.0) * cross(w0, w1)
    return S, C


def _lagrange(nodes: np.ndarray, x: np.ndarray, skip: np.ndarray) -> np.ndarray:
    """Weights (m, 4) of the cubic through each row of nodes (m, 4), evaluated at x (m,); rows in `skip`
    (streams too short for a cubic) get finite placeholders."""
    nodes = np.where(skip[:, None], np.arange(4.0), nodes)
    W = np.ones(nodes.shape)
    for j in range(4):
        for i in range(4):
            if i != j:
                W[:, j] *= (x - nodes[:, i]) / (nodes[:, j] - nodes[:, i])
    return W


def quat_exp(phi: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion(s) (..., 4) of rotation vectors phi (..., 3)."""
    return np.stack(_exp_components(np.asarray(phi, dtype=float)), axis=-1)


def _exp_components(phi: np.ndarray) -> tuple[np.ndarray, ...]:
    # Per-sample rotations are small, so a series (error < 2e-14 below 0.05 rad) replaces sin/cos
    # and the 0/0 at zero; larger steps take the exact branch.
    x, y, z = phi[..., 0], phi[..., 1], phi[..., 2]
    a2 = x * x + y * y + z * z
    if a2.size and a2.max() < 0.0025:
        w = 1.0 - a2 * (1.0 / 8.0) + a2 * a2 * (1.0 / 384.0)
        k = 0.5 - a2 * (1.0 / 48.0) + a2 * a2 * (1.0 / 3840.0)
    else:
        a = np.sqrt(a2)
        w = np.cos(0.5 * a)
        small = a < 1e-4
        k = np.where(small, 0.5 - a2 / 48.0, np.sin(0.5 * a) / np.where(small, 1.0, a))
    return w, k * x, k * y, k * z


def _qmul(p: tuple, q: tuple) -> tuple:
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


# Left-multiplication matrix of a quaternion p: p q = (p[..., _L_IDX] * _L_SIGN) @ q.
_L_IDX = np.array([[0, 1, 2, 3], [1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]])
_L_SIGN = np.array([[1, -1, -1, -1], [1, 1, -1, 1], [1, 1, 1, -1], [1, -1, 1, 1]], dtype=float)
# Below this many quaternions per level, numpy's per-call overhead dominates the 28 component ufuncs
# and one batched 4x4 matmul per level is faster (measured ~2x on 19 x 400 products).
_MATMUL_BELOW = 1024


def _matmul_qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return ((p[..., _L_IDX] * _L_SIGN) @ q[..., None])[..., 0]


def _ordered_product(q: tuple) -> np.ndarray:
    """q_0 q_1 ... q_{n-1} along the last axis of the four component arrays (..., n), as (..., 4).

    Pairwise (associative) reduction: component ufuncs while the levels are large, stacked 4x4
    matmuls once they are small. An odd element at the end of a level is set aside and multiplied
    on the right at the end, later levels' leftovers first (they come earlier in time).
    """
    tails = []
    while q[0].shape[-1] > 1 and q[0].size > _MATMUL_BELOW:
        if q[0].shape[-1] % 2:
            tails.append(np.stack([c[..., -1] for c in q], axis=-1))
            q = tuple(c[..., :-1] for c in q)
        q = _qmul(tuple(c[..., 0::2] for c in q), tuple(c[..., 1::2] for c in q))
    Q = np.stack(q, axis=-1)
    while Q.shape[-2] > 1:
        if Q.shape[-2] % 2:
            tails.append(Q[..., -1, :])
            Q = Q[..., :-1, :]
        Q = _matmul_qmul(Q[..., 0::2, :], Q[..., 1::2, :])
    Q = Q[..., 0, :]
    for tail in reversed(tails):
        Q = _matmul_qmul(Q, tail)
    return Q


def product_of_exps(phi: np.ndarray) -> np.ndarray:
    """exp(phi_0) exp(phi_1) ... over axis -2 of rotation vectors (..., n, 3), as quaternions (..., 4)."""
    if phi.shape[-2] == 0:
        q = np.zeros(phi.shape[:-2] + (4,))
        q[..., 0] = 1.0
        return q
    return _ordered_product(_exp_components(phi))


def integrate_quaternion(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Scalar-first quaternion(s) (..., 4) of R(t0)^T R(t_end) for rates omega (..., m, 3) on times t (m,)."""
    t = np.asarray(t, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if t.ndim != 1 or omega.shape[-2:] != (t.size, 3):
        raise ValueError(f"integrate: t has shape {t.shape}, omega {omega.shape}; need t (m,) and omega (..., m, 3)")
    if t.size < 2:
        q = np.zeros(omega.shape[:-2] + (4,))
        q[..., 0] = 1.0
        return q
    if np.any(np.diff(t) <= 0):
        bad = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise ValueError(f"integrate: time stamps must increase; t[{bad}]={t[bad]!r} >= t[{bad + 1}]={t[bad + 1]!r}")
    q = product_of_exps(interval_rotvecs(t, omega))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def integrate_rotation(t: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Body rotation R(t0)^T R(t_end) (3, 3) (or stacked (..., 3, 3)) from fixture-frame rates in rad/s."""
    return matrix_from_quat(integrate_quaternion(t, omega))
