"""The small typed protocols procedures compose: a sensor triad, a board, a table, a session store."""

from __future__ import annotations

from typing import Callable, Protocol

import numpy as np


class Triad(Protocol):
    def read_raw(self) -> tuple[int, int, int]: ...


class Board(Protocol):
    triads: dict[str, Triad]          # "accel" | "gyro" | "mag"
    parts: list                       # every part (drivers.contract.Part), e.g. to check their configuration

    def start(self) -> None: ...

    def read_temperature(self) -> float | None: ...

    def read_supply(self) -> float | None: ...

    def settings(self) -> dict: ...


class Table(Protocol):
    """A two-axis table whose moves report every status poll to `on_poll(statuses)` and pass the time
    between polls through `wait(dt)`.

    The procedure samples its sensors inside `wait`, so the gyro stream of every move is recorded at the
    full rate, without gaps, while the table's move protocol runs unchanged.
    """

    def enable(self) -> None: ...

    def set_watchdog(self, ms: int) -> None: ...

    def move_to(self, outer_deg: float, inner_deg: float, *, speed_dps: float, accel_dps2: float,
                tolerance_deg: float, settle_s: float, on_poll: Callable[[list], None] | None = None,
                wait: Callable[[float], None] | None = None) -> list: ...

    def positions(self) -> tuple[float, float]: ...

    def make_safe(self) -> None: ...


class Store(Protocol):
    def append_hold(self, step: int, *, t: np.ndarray, samples: dict, q_ref: np.ndarray, table_deg: np.ndarray,
                    commanded_deg, measured_deg, temp_c=None, vsupply_v=None, attempt: int = 1) -> None: ...

    def append_move(self, step: int, *, t, samples, q_ref, table_deg, temp_c=None, vsupply_v=None) -> None: ...

    def redo(self, t: float, reason: str) -> None:
        """Forget the move appended last (not committed with its hold): the step is redone from time `t`."""

    def log_event(self, kind: str, message: str, t: float | None = None) -> None: ...
