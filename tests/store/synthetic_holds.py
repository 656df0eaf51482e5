"""Deterministic synthetic holds and moves for the store tests (also run by the SIGKILL child process).

Every array is a function of (step, attempt) only, so a process that reopens the file can check
a committed hold cell by cell without sharing state with the writer.
"""

from __future__ import annotations

import numpy as np

from rig.rotations import TableGeometry, quat_from_matrix

HOLD_S = 5.0
MOVE_S = 2.0
RATE_HZ = 100.0
CYCLE_S = 2 * HOLD_S + MOVE_S + 1.0     # room for a repeated hold before the move


def schedule(step: int) -> tuple[float, float]:
    """(outer, inner) table angles in deg of orientation `step`."""
    return (45.0 * (step % 8), 90.0 * ((step // 2) % 4))


def hold_arrays(step: int, attempt: int = 1, n: int = int(HOLD_S * RATE_HZ)) -> dict:
    """Keyword arguments of `append_hold` for one hold: accel+gyro every row, mag every other row."""
    rng = np.random.default_rng(1000 * step + attempt)
    t0 = step * CYCLE_S + (attempt - 1) * HOLD_S
    t = t0 + np.arange(n) / RATE_HZ
    outer, inner = schedule(step)
    R = TableGeometry().rotation(outer, inner)
    q = np.tile(quat_from_matrix(R), (n, 1))
    mag = rng.normal(200.0, 3.0, (n, 3)).round()
    mag[1::2] = np.nan
    return dict(
        t=t,
        samples={"accel": rng.normal(1000.0 * step, 5.0, (n, 3)).round(),
                 "gyro": rng.normal(0.0, 2.0, (n, 3)).round(),
                 "mag": mag},
        q_ref=q,
        table_deg=np.tile([outer, inner], (n, 1)) + rng.normal(0, 1e-3, (n, 2)),
        commanded_deg=(outer, inner),
        measured_deg=(outer + 0.001, inner - 0.002),
        temp_c=25.0 + 0.01 * np.arange(n) / RATE_HZ,
        vsupply_v=np.full(n, 3.3),
        attempt=attempt,
    )


def move_arrays(step: int, n: int = int(MOVE_S * RATE_HZ)) -> dict:
    """Keyword arguments of `append_move` for the move leaving orientation `step`."""
    rng = np.random.default_rng(50_000 + step)
    t0 = step * CYCLE_S + 2 * HOLD_S + 0.5
    t = t0 + np.arange(n) / RATE_HZ
    a0, b0 = schedule(step)
    a1, b1 = schedule(step + 1)
    s = np.linspace(0.0, 1.0, n)
    angles = np.column_stack([a0 + (a1 - a0) * s, b0 + (b1 - b0) * s])
    q = quat_from_matrix(TableGeometry().rotation(angles[:, 0], angles[:, 1]))
    return dict(t=t, samples={"accel": rng.normal(0, 50, (n, 3)).round(), "gyro": rng.normal(0, 500, (n, 3)).round()},
                q_ref=q, table_deg=angles)
