"""Plan the orientations of a calibration session so every axis is excited.

On a tumble table (conventions.md) gravity in the fixture frame is (sin a sin b, sin a cos b, cos a) up
to signs, so the outer angle is a polar angle and the inner one an azimuth: spreading the reference
direction evenly over the sphere (a Fibonacci lattice) excites all three axes of every sensor. The order
is a nearest-neighbour tour so moves stay short, and every move turns both axes, so the gyro sees
rotation about all three of its axes across the session.

Every reference direction has two table poses, (a, b) and (-a, b + 180): the same gravity direction in the
fixture, the unit turned half a turn about the vertical. Every second lattice point takes the second pose.
That turn is what tells the table's tilt (and the magnetic field's direction) apart from the mounting part of
H: on the 12- and 20-point lattices it lowers the Cramer-Rao bound of the accelerometer's H by 39 % and of B
by 20 %, and of the magnetometer's H by 24 % and B by 29 % (bounds.py; the best of 300 random choices of which
points to turn is no better), for 3-7 % more rig time. A second pose outside the table's limits is not taken.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rig.rotations import TableGeometry
from rig.trapezoid import trapezoid


@dataclass(frozen=True)
class Orientation:
    outer_deg: float
    inner_deg: float


def plan_orientations(n: int = 20, *, outer_limits=(-180.0, 180.0), inner_limits=(-180.0, 180.0),
                      seed: int | None = None) -> list[Orientation]:
    """`n` orientations (10 to 20 typical) spread over the sphere of reference directions."""
    if not 6 <= n <= 64:
        raise ValueError(f"number of orientations must be between 6 and 64, got {n}")
    k = np.arange(n) + 0.5
    polar = np.degrees(np.arccos(1 - 2 * k / n))            # 0..180
    azimuth = (np.degrees(k * math.pi * (3 - math.sqrt(5))) % 360.0) - 180.0
    if seed is not None:
        azimuth = ((azimuth + np.random.default_rng(seed).uniform(0, 360)) % 360.0) - 180.0
    turned = np.arange(n) % 2 == 1                          # the second pose of the same direction
    azimuth_turned = (azimuth + 360.0) % 360.0 - 180.0
    turned &= ((outer_limits[0] <= -polar) & (-polar <= outer_limits[1])
               & (inner_limits[0] <= azimuth_turned) & (azimuth_turned <= inner_limits[1]))
    polar = np.where(turned, -polar, polar)
    azimuth = np.where(turned, azimuth_turned, azimuth)
    pts = [Orientation(round(float(a), 3), round(float(b), 3)) for a, b in zip(polar, azimuth)]
    for p in pts:
        if not (outer_limits[0] <= p.outer_deg <= outer_limits[1] and inner_limits[0] <= p.inner_deg <= inner_limits[1]):
            raise ValueError(f"orientation {p} outside the table limits {outer_limits}, {inner_limits}")
    return _tour(pts)


def _tour(pts: list[Orientation]) -> list[Orientation]:
    left, order = pts[1:], [pts[0]]
    while left:
        last = order[-1]
        nxt = min(left, key=lambda p: max(abs(p.outer_deg - last.outer_deg), abs(p.inner_deg - last.inner_deg)))
        left.remove(nxt)
        order.append(nxt)
    return order


def schedule_rotations(schedule: list[Orientation], geometry: TableGeometry | None = None) -> np.ndarray:
    g = geometry or TableGeometry()
    return g.rotation([o.outer_deg for o in schedule], [o.inner_deg for o in schedule])


def estimate_duration(schedule: list[Orientation], *, hold_s: float, speed_dps: float, accel_dps2: float,
                      settle_s: float) -> float:
    """Seconds of rig time: holds plus trapezoidal moves (the slower axis of each move)."""
    total = hold_s * len(schedule)
    for p, q in zip(schedule[:-1], schedule[1:]):
        d = max(abs(q.outer_deg - p.outer_deg), abs(q.inner_deg - p.inner_deg))
        total += settle_s + trapezoid(d, speed_dps, accel_dps2).duration
    return total
