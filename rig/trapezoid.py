"""A rest-to-rest move under limits of speed, acceleration and deceleration: the trapezoidal (or, when the move
is too short to reach full speed, triangular) profile that the table's drives run, the fake table simulates and
the planner and the link expect."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Trapezoid:
    """Phases of the fastest move over `distance` (deg): accelerate, cruise at `peak`, decelerate (s, deg/s)."""

    peak: float
    t_accel: float
    t_cruise: float
    t_decel: float

    @property
    def duration(self) -> float:
        return self.t_accel + self.t_cruise + self.t_decel


def trapezoid(distance: float, speed: float, accel: float, decel: float | None = None) -> Trapezoid:
    """The profile of a move of `abs(distance)`; the peak is `speed` unless the move is too short to reach it,
    then `sqrt(2 d a b / (a + b))` where acceleration and deceleration meet."""
    decel = accel if decel is None else decel
    distance = abs(distance)
    if distance == 0:
        return Trapezoid(0.0, 0.0, 0.0, 0.0)
    peak = min(speed, math.sqrt(2 * distance * accel * decel / (accel + decel)))
    t_accel, t_decel = peak / accel, peak / decel
    cruise = distance - 0.5 * peak * (t_accel + t_decel)
    return Trapezoid(peak, t_accel, max(cruise, 0.0) / peak, t_decel)
