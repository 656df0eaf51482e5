"""Injected time.

Everything that waits or timestamps takes a `Clock`, so the simulated rig runs a 150 s session in a
fraction of a second and deterministically, while the real rig waits on real time.
"""

from __future__ import annotations

import threading
import time
from typing import Protocol


class Clock(Protocol):
    """Monotonic seconds and a way to wait."""

    def now(self) -> float: ...

    def sleep(self, dt: float) -> None: ...


class RealClock:
    """Wall time: `time.monotonic` and `time.sleep`."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, dt: float) -> None:
        if dt > 0:
            time.sleep(dt)


class SimClock:
    """Virtual time that advances only when someone sleeps.

    With `time_scale=None` a sleep returns at once; with `time_scale=X` it also waits `dt / X` of
    wall time, so a simulated rig can run at X times real time and be interrupted from outside.
    Thread-safe: the fake turntable's server thread reads `now()` while the procedure sleeps.
    """

    def __init__(self, start: float = 0.0, time_scale: float | None = None) -> None:
        if time_scale is not None and time_scale <= 0:
            raise ValueError(f"time_scale must be positive, got {time_scale}")
        self._t = float(start)
        self._lock = threading.Lock()
        self.time_scale = time_scale

    def now(self) -> float:
        return self._t          # reading one attribute is atomic; the lock serialises the sleeps' updates

    def sleep(self, dt: float) -> None:
        if dt <= 0:
            return
        if self.time_scale is not None:
            time.sleep(dt / self.time_scale)
        with self._lock:
            self._t += dt

    def advance_to(self, t: float) -> None:
        """Jump forward to `t` (never backwards)."""
        self.sleep(t - self.now())


def sleep_until(clock: Clock, t: float) -> None:
    """Wait until `clock.now() >= t`."""
    dt = t - clock.now()
    if dt > 0:
        clock.sleep(dt)
