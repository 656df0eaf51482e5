"""A ramp judged from the unit's own thermometers: the die brought to a steady, known rate of change, so that a
step's schedule can be measured while it moves (a ramped step of a thermal session, what makes a thermal lag
observable: on soaked steps the die stands still and a lag shows nothing).

The chamber's controller ramps its set point at `rate_c_per_min` from where it is towards `to_c`. Every `poll_s`
the chips' thermometer and the chamber's air are read. Ready, all at once:
- the die's slope, fitted by least squares over the readings of the last `window_s` (`procedures.soak`), is the
  ramp's rate within `slope_c_per_min` (the soak's own criterion, about the ramp's rate instead of zero);
- the die has come to `start_c` (the schedule then runs across the step's temperature, centred on it when
  `start_c` is that temperature less half the die's travel during the schedule).
Not ready before the die passes `give_up_c` (the step's schedule could no longer be run on a steady ramp before
the die is beyond it: the moves between set points are too short for the chamber to reach the rate) or after
`max_s`: `SoakNotSettled`, a fault (exit 3). A controller alarm on the way: `ChamberAlarm`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from procedures.soak import Soak, SoakNotSettled, watch_die
from rig.chamber.client import ChamberLink
from rig.clock import Clock


@dataclass(frozen=True)
class RampSettings:
    rate_c_per_min: float             # the ramp's rate, signed: rising positive
    slope_c_per_min: float = 0.1      # steady: the die's slope within this of the rate
    window_s: float = 60.0
    poll_s: float = 5.0
    max_s: float = 7200.0


def ramp_until(chamber: ChamberLink, read_die: Callable[[], float | None], clock: Clock, to_c: float,
               start_c: float, give_up_c: float, settings: RampSettings) -> Soak:
    """Ramp the chamber towards `to_c` and return once the die moves at the rate and has come to `start_c` (module
    docstring); the chamber keeps ramping. The result is a `Soak` whose `set_point_c` is `to_c`."""
    rate = settings.rate_c_per_min
    sign = math.copysign(1.0, rate)
    start = clock.now()
    chamber.ramp_rate(abs(rate))
    chamber.set_point(to_c)
    chamber.run()
    for r in watch_die(chamber, read_die, clock, settings.window_s, settings.poll_s,
                       f"ramping towards {to_c:g} C"):
        slope, die = r.slope_c_per_min, r.die_c
        steady = slope is not None and abs(slope - rate) < settings.slope_c_per_min
        if steady and sign * (die - start_c) >= 0:
            return Soak(to_c, start, r.now, slope, die, r.status.air_c, r.readings, r.die_start_c, rate)
        said = "no slope yet" if slope is None else f"{slope:+.3f} C/min"
        if sign * (die - give_up_c) > 0:
            raise SoakNotSettled(
                f"the die passed {give_up_c:.2f} C ramping towards {to_c:g} C before it moved steadily at "
                f"{rate:+g} C/min (die {die:.2f} C, {said}, within {settings.slope_c_per_min:g} C/min): the move "
                "between set points is too short for the chamber to reach the rate; lower [thermal] "
                "ramp_c_per_min or space the set points further apart")
        if r.now - start >= settings.max_s:
            raise SoakNotSettled(
                f"not ramping steadily at {rate:+g} C/min towards {to_c:g} C after {settings.max_s:g} s: die "
                f"{die:.2f} C ({said}), air {r.status.air_c:.2f} C; the chamber cannot follow the ramp, or "
                "[thermal] max_soak_s is too short for the fixture")
    raise AssertionError("unreachable: watch_die polls until its caller returns or raises")
