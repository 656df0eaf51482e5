"""The model behind a recording's magnetometer fit (`mag_fit`): every sample's field magnitude, and each group's
cosine between the field and its direction (a still pose's gravity, a turn's axis).

The angle is a cosine, of the field's direction alone, not the dot product `g_k . v_k`: a pose's mean is made of
samples the magnitude's group already holds, and a dot product with gravity (30 deg from the field at a 60 deg
dip) reads mostly their radial noise again, counted twice as if independent. The cosine's noise is the tangential
part, which the magnitudes do not see (first order: d(g.v/|v|) = (g - (g.e) e) . dv / |v|, e = v/|v|). With the
dot product, 30 noise draws of one synthetic hand session scattered 1.0 to 1.47 times the stated deviation
of B's and H's entries (11 of 12 above 1.2).
"""

from __future__ import annotations

import numpy as np


def residuals(p: np.ndarray, y: np.ndarray, groups: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The magnitudes |H (y - B)| - 1 of samples y, then each group's cosines to its directions less its own c;
    p = (B, vec H / M, c per group)."""
    B, H = p[:3], p[3:12].reshape(3, 3)
    parts = [np.linalg.norm((y - B) @ H.T, axis=1) - 1.0]
    parts += [(_unit((gy - B) @ H.T) * d).sum(axis=1) - c for (gy, d), c in zip(groups, p[12:])]
    return np.concatenate(parts)


def jacobian(p: np.ndarray, y: np.ndarray, groups: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """d residuals / d p."""
    B, H = p[:3], p[3:12].reshape(3, 3)
    extra = len(groups)
    d = y - B
    e = (d @ H.T) / np.linalg.norm(d @ H.T, axis=1, keepdims=True)
    rows = [np.hstack([-e @ H, np.einsum("ni,nj->nij", e, d).reshape(len(y), 9), np.zeros((len(y), extra))])]
    for k, (gy, u) in enumerate(groups):
        c = np.zeros((len(gy), extra))
        c[:, k] = -1.0
        v = (gy - B) @ H.T
        e = _unit(v)
        q = (u - (u * e).sum(axis=1, keepdims=True) * e) / np.linalg.norm(v, axis=1, keepdims=True)
        rows.append(np.hstack([-q @ H, np.einsum("ki,kj->kij", q, gy - B).reshape(len(gy), 9), c]))
    return np.vstack(rows)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True)
