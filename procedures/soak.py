"""A soak judged from the unit's own thermometers: the chamber goes to a set point, and the unit is soaked once the
die temperature the chips read has stopped moving, not after a fixed wait.

Every `poll_s` the chips' thermometer and the chamber's air are read. Soaked when, all at once:
- the air is within the chamber's tolerance of the set point;
- the die temperature's slope, fitted by least squares over the readings of the last `window_s`, is below
  `slope_c_per_min` in magnitude (a window's slope is the die's slope near the window's middle, so the soak ends
  about half a window after the die truly settles; a window of a few percent of the soak keeps that small);
- at least `min_soak_s` have passed since the set point was written (before the heat reaches it, a die that has
  not yet started to move has no slope either).
Not soaked after `max_soak_s`: `SoakNotSettled`, a fault (exit 3). A controller alarm on the way: `ChamberAlarm`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from rig.chamber.client import ChamberLink, ChamberStatus
from rig.chamber.errors import ChamberAlarm
from rig.clock import Clock
from rig.errors import RigError


class SoakNotSettled(RigError):
    """The die did not settle at a set point within the longest soak allowed."""


@dataclass(frozen=True)
class SoakSettings:
    slope_c_per_min: float = 0.1
    window_s: float = 60.0
    poll_s: float = 5.0
    min_soak_s: float = 120.0
    max_soak_s: float = 7200.0
    tolerance_c: float = 0.5          # the air at its set point within this (the chamber's [chamber] tolerance_c)


@dataclass
class Soak:
    """One soak: clock times of its start (set point written) and end, what the die read at the end."""

    set_point_c: float
    start_s: float
    end_s: float
    slope_c_per_min: float
    die_c: float
    air_c: float
    readings: list[tuple[float, float]] = field(default_factory=list)     # (clock s, die C)
    die_start_c: float = float("nan")     # the die's first reading: where the approach to the set point began
    ramp_c_per_min: float = 0.0           # the controller's ramp towards the set point (a ramp, procedures.ramp)

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def to_dict(self) -> dict:
        return {"set_point_c": self.set_point_c, "start_s": round(self.start_s, 3), "end_s": round(self.end_s, 3),
                "duration_s": round(self.duration_s, 3), "die_slope_c_per_min": round(self.slope_c_per_min, 5),
                "die_c": round(self.die_c, 4), "air_c": round(self.air_c, 4), "readings": len(self.readings),
                "die_start_c": round(self.die_start_c, 4), "ramp_c_per_min": self.ramp_c_per_min}


def window_slope(readings: list[tuple[float, float]], now: float, window_s: float) -> float | None:
    """The die's slope in C/min over the readings of the last `window_s` (least squares); None until the readings
    cover the whole window."""
    if not readings or readings[0][0] > now - window_s:
        return None
    t = np.array([r[0] for r in readings if r[0] >= now - window_s - 1e-9])
    T = np.array([r[1] for r in readings if r[0] >= now - window_s - 1e-9])
    if len(t) < 3 or np.ptp(t) <= 0:
        return None
    return float(np.polyfit(t - t[0], T, 1)[0] * 60.0)


@dataclass
class DieReading:
    """One poll of a soak or a ramp: the clock, the die and the chamber as read, the die's slope over the window
    (None until the readings cover it), the readings so far and the die's first reading."""

    now: float
    die_c: float
    status: ChamberStatus
    slope_c_per_min: float | None
    readings: list[tuple[float, float]]
    die_start_c: float


def watch_die(chamber: ChamberLink, read_die: Callable[[], float | None], clock: Clock, window_s: float,
              poll_s: float, doing: str, on_reading: Callable[[float, float, float], None] | None = None
              ) -> Iterator[DieReading]:
    """Every `poll_s`: the chamber's status and the die, with the die's slope over `window_s`; a controller alarm
    raises `ChamberAlarm`, a thermometer without a reading `SoakNotSettled`. `doing` ("soaking at 25 C") names
    the wait in those messages; `on_reading(t, die, air)` sees every reading."""
    readings: list[tuple[float, float]] = []
    first: float | None = None
    while True:
        now = clock.now()
        status = chamber.status()
        if status.alarm:
            raise ChamberAlarm(f"{chamber.url}: the controller reports {status.alarm} while {doing}")
        die = read_die()
        if die is None or not np.isfinite(die):
            raise SoakNotSettled(f"the unit's thermometer gives no reading while {doing}; the wait is judged from it")
        readings.append((now, float(die)))
        first = float(die) if first is None else first
        if on_reading is not None:
            on_reading(now, float(die), status.air_c)
        yield DieReading(now, float(die), status, window_slope(readings, now, window_s), readings, first)
        readings = [r for r in readings if r[0] >= now - window_s - poll_s]
        clock.sleep(poll_s)


def soak(chamber: ChamberLink, read_die: Callable[[], float | None], clock: Clock, set_point_c: float,
         settings: SoakSettings, on_reading: Callable[[float, float, float], None] | None = None) -> Soak:
    """Write the set point, run the chamber and wait until the die is soaked (module docstring).

    `read_die()`: the die temperature the chips read now (C); `on_reading(t, die, air)` sees every reading."""
    start = clock.now()
    chamber.set_point(set_point_c)
    chamber.run()
    for r in watch_die(chamber, read_die, clock, settings.window_s, settings.poll_s,
                       f"soaking at {set_point_c:g} C", on_reading):
        slope, air = r.slope_c_per_min, r.status.air_c
        air_there = abs(air - set_point_c) <= settings.tolerance_c
        if (air_there and slope is not None and abs(slope) < settings.slope_c_per_min
                and r.now - start >= settings.min_soak_s):
            return Soak(set_point_c, start, r.now, slope, r.die_c, air, r.readings, r.die_start_c)
        if r.now - start >= settings.max_soak_s:
            said = "no slope yet" if slope is None else f"{slope:+.3f} C/min"
            raise SoakNotSettled(
                f"not soaked at {set_point_c:g} C after {settings.max_soak_s:g} s: die {r.die_c:.2f} C ({said}, "
                f"threshold {settings.slope_c_per_min:g} C/min), air {air:.2f} C; the chamber cannot hold "
                "the set point, or [thermal] max_soak_s is too short for the fixture")
    raise AssertionError("unreachable: watch_die polls until its caller returns or raises")
