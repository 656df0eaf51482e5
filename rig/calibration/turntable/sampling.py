"""Whether a gyro's samples are dense enough to integrate its motions at all.

The rate between two samples is unknown; the integration assumes it (a cubic through four samples, or a mean
with the coning term). Where a motion turns tens of degrees between samples, that assumption is off by more
than the rate noise leaves in the motion, the fit explains the difference with a wrong H, and its stated
uncertainty (scaled by the same misfit) may even look modest: a turntable session logged at 1.5 Hz gave an H
thousands of times too large with exit 0. The error is measured on the data themselves by step doubling:
each motion integrated from every sample and from every second one; a scheme of order p is off by
d / (2^p - 1) at the finer step, p = 2 taken here (a corner of the rate profile, or a rate axis that turns,
leaves the schemes second order). The rate noise's own share of d (the angle random walk of the motion) is
taken out, and what is left is set against that noise: more than MARGIN times it, H cannot be trusted to its
stated uncertainty and the recording is refused, naming the rotation between samples that could be integrated
(the error grows as the square of the step, so the limit is the worst step times sqrt(MARGIN * noise / error)).

That refusal is the turntable's (`rig.pipeline.solving`). A hand recording's gyro (`turntable_free_gyro`) states
the integration error in its deviation instead (`carried_gravity`) and is judged against that deviation
(`HandIntegration`): a warning where step doubling shows more error than the deviation would hold without it, a
refusal only where the deviation stated is more than a calibration can be told to, or step doubling shows far more
error than it covers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.calibration.turntable.gyro import MoveSet, decimated, integrated_quats
from rig.errors import CalibrationError
from rig.quaternions import quat_conjugate, quat_multiply, rotvec_from_quat
from rig.session_data import MoveStream

ORDER = 2          # the schemes' order where the rate profile has corners or its axis turns
MARGIN = 5.0       # integration error per motion allowed, in units of the rate noise's angle per motion ...
REL_FLOOR = 2e-5   # ... or of this share of the motion's angle: a nearly noiseless gyro (an independent simulator's
# noise-free session: 0.0003 mrad of noise) would be refused for 0.02 mrad per 90 deg motion, an H error of 1e-5,
# ten times below the best gyro H this rig resolves (0.02 %, see the planning guide)
# Where the misfit shows, the fit's stated uncertainty grows with it and covers the error; beyond this, H absorbed
# it. Measured on synthetic sessions (tests/io, tests/recordings): right within 2 of their standard deviations at
# up to 3.3 times (trapezoid moves with corners at 50 Hz, cosine moves at 3-3.5 Hz, hand motions at 3 Hz), wrong by
# 4-9 of them from 5.6 times (cosine moves at 2-2.5 Hz), thousands of times at 24 (1.5 Hz).
TABLE_MARGIN = 20.0
# A turntable session is refused only beyond this: below it the table's session is off by tenths of a percent, which
# the coarse-sampling warning states (a 2-2.5 Hz log 0.3-0.7 %; the emulated gyro of the mixed rig, chips emulated
# against a table in another process, 0.6 % at 6-11 times), beyond it by percents to thousands of times (1.5 Hz:
# 24 times). A hand recording has no such warning and no table reference to check its moves against.


@dataclass
class Coarseness:
    """What step doubling says of a set of motions (angles in rad, rotation between samples in deg)."""

    worst_deg: float        # the largest rotation between two consecutive samples
    error_rad: float        # RMS integration error per motion at the recorded step (noise taken out)
    noise_rad: float        # RMS angle random walk of the rate noise per motion
    limit_deg: float        # the rotation between samples at which the error would be MARGIN times the allowance
    motions: int
    angle_rad: float = 0.0  # RMS angle the motions turn through (their paths)
    margin: float = MARGIN

    @property
    def allowance_rad(self) -> float:
        return max(self.noise_rad, REL_FLOOR * self.angle_rad)

    @property
    def too_coarse(self) -> bool:
        return self.error_rad > self.margin * self.allowance_rad

    def refusal(self, what: str, rate_hz: float | None) -> str:
        """One sentence for the refusal; `what`: 'the table' or 'the unit'."""
        at = f" (samples at {rate_hz:.3g} Hz)" if rate_hz else ""
        return (f"{what} turns up to {self.worst_deg:.3g} deg between two gyro samples{at}; integrated across "
                f"{self.motions} motions that leaves {1e3 * self.error_rad:.3g} mrad per motion, "
                f"{self.error_rad / self.allowance_rad:.3g} times the rate noise's {1e3 * self.noise_rad:.3g} mrad "
                f"or {REL_FLOOR:g} of the motion, the larger "
                f"(found by integrating every second sample); at most about {self.limit_deg:.2g} deg between "
                f"samples can be integrated here: sample faster or move slower")


def rotation_steps(moves: list[MoveStream], B: np.ndarray, H: np.ndarray) -> list[np.ndarray]:
    """The angle (rad) each motion turns between consecutive samples, at the rate `H (y - B)`."""
    return [np.linalg.norm((m.y[1:] - B) @ H.T, axis=1) * np.diff(m.t) for m in moves]


def coarseness(moves: list[MoveStream], B: np.ndarray, H: np.ndarray, rate_noise_counts: np.ndarray,
               samples: str = "point", margin: float = MARGIN) -> Coarseness:
    """Step doubling of every motion at a calibration H (a nominal one is enough: the comparison is relative).

    rate_noise_counts: the per-sample white noise of each raw axis (from the rests)."""
    H = np.asarray(H, dtype=float)
    full = integrated_quats(H, MoveSet.build(moves, B, samples))
    half = integrated_quats(H, MoveSet.build(decimated(moves, 2), B, samples))
    d = np.linalg.norm(rotvec_from_quat(quat_multiply(quat_conjugate(full), half)), axis=-1)
    noise_rate = float(np.trace(H @ np.diag(np.asarray(rate_noise_counts, float) ** 2) @ H.T))
    walk = noise_rate * np.array([np.sum(np.diff(m.t) ** 2) for m in moves])
    excess = max(float(np.mean(d ** 2) - np.mean(walk)), 0.0)
    error = np.sqrt(excess) / (2 ** ORDER - 1)
    noise = float(np.sqrt(np.mean(walk)))
    steps = rotation_steps(moves, B, H)
    worst_deg = float(np.degrees(max(float(np.max(step)) for step in steps)))
    path = float(np.sqrt(np.mean([np.sum(step) ** 2 for step in steps])))      # a full turn's net rotation is 0
    found = Coarseness(worst_deg, float(error), noise, float("inf"), len(moves), path, margin)
    if error > 0:
        found.limit_deg = worst_deg * (margin * found.allowance_rad / error) ** (1.0 / ORDER)
    return found


def refuse_coarse_motions(source: str | None, what: str, moves: list[MoveStream], B: np.ndarray, H: np.ndarray,
                          rate_noise_counts: np.ndarray, rate_hz: float | None, margin: float = MARGIN) -> Coarseness:
    """Raise CalibrationError when the motions cannot be integrated (Coarseness.too_coarse at `margin`), naming the
    recording (`source`; None where the caller names it)."""
    found = coarseness(moves, B, H, rate_noise_counts, margin=margin)
    if found.too_coarse:
        raise CalibrationError(f"{source + ': ' if source else ''}gyro: {found.refusal(what, rate_hz)}")
    return found


HAND_TOLD_REL = 0.05   # a gyro H told by hand motions to no better than this (its stated deviation, relative) is not
# calibrated: a MEMS gyro's datasheet gives its scale to 1-3 %
HAND_MARGIN = 10.0     # step doubling's integration error beyond this many times what the stated deviation covers:
# the fit's account of the rate between samples (`carried_gravity`) no longer holds. Its order-2 reading overstates
# a smooth motion's error up to five times (the cubic is fourth order there); synthetic quick hand motions at 100 Hz
# whose stated deviation covered their error (RMS z near 1) read 1.3-2.9 times, a hand session at 5 Hz 3.1.


@dataclass
class HandIntegration:
    """What integrating a hand recording's motions at their sample rate leaves, against the deviation its gyro's
    H states (`turntable_free_gyro`): step doubling (`coarseness`) and the fit's own account."""

    found: Coarseness
    stated_rel: float         # H's stated deviation (RMS over its diagonal) relative to its mean diagonal
    without_rel: float        # the same without the share of the rate between samples
    rate_hz: float | None

    @property
    def error_rel(self) -> float:
        """Step doubling's integration error per motion relative to the angle the motions turn."""
        return self.found.error_rad / self.found.angle_rad if self.found.angle_rad > 0 else 0.0

    @property
    def quick(self) -> bool:
        """Motions quick for the sample rate: the integration error step doubling shows is beyond the deviation
        H would state without it."""
        return self.error_rel > self.without_rel

    @property
    def refused(self) -> bool:
        return self.stated_rel > HAND_TOLD_REL or self.error_rel > HAND_MARGIN * self.stated_rel

    def _turns(self) -> str:
        at = f" (samples at {self.rate_hz:.3g} Hz)" if self.rate_hz else ""
        return f"the unit turns up to {self.found.worst_deg:.3g} deg between two gyro samples{at}"

    def warning(self) -> str:
        return (f"quick motions for the sample rate: {self._turns()}; integrating them leaves about "
                f"{1e3 * self.found.error_rad:.2g} mrad per motion (found by integrating every second sample), and "
                f"H_std takes in the integration error: {100 * self.stated_rel:.2g} % of H, "
                f"{100 * self.without_rel:.2g} % without it")

    def refusal(self) -> str:
        if self.stated_rel > HAND_TOLD_REL:
            return (f"{self._turns()}; the gravity its {self.found.motions} motions carry tells H only to "
                    f"{100 * self.stated_rel:.3g} % (its stated deviation, the integration error of the sample rate "
                    f"included), more than the {100 * HAND_TOLD_REL:g} % a calibration must be told to: sample faster "
                    "or move slower")
        return (f"{self._turns()}; integrating every second sample moves its {self.found.motions} motions by "
                f"{1e3 * self.found.error_rad:.3g} mrad, {self.error_rel / self.stated_rel:.3g} times the "
                f"{100 * self.stated_rel:.2g} % of H its stated deviation covers, more than the {HAND_MARGIN:g} times "
                "the fit can tell: sample faster or move slower")


HOLE_PERIODS = 1.5   # an interval longer than this many sample periods has lost samples ...
HOLE_TURN_DEG = 0.1  # ... which matter where the gyro turned this much across it
JITTER_SHARE = 0.1   # stamps scattered (RMS) by more than this share of the period do not mark the sample instants


@dataclass
class MoveTiming:
    """How regularly a gyro's move samples were taken, from their time stamps and rates."""

    period_s: float         # the median interval
    missing: int            # samples missing inside the motions where the gyro turned across the hole
    holes: int
    longest_hole_s: float
    worst_hole_deg: float   # the most the gyro turned across one hole
    jitter_s: float         # RMS scatter of the other intervals about the period

    @property
    def irregular(self) -> bool:
        return self.missing > 0 or self.jitter_s > JITTER_SHARE * self.period_s


def move_timing(moves: list[MoveStream], B: np.ndarray, H: np.ndarray) -> MoveTiming:
    """Lost samples and scattered stamps in the motions. A chip that holds only its newest sample loses every
    sample its reader comes too late for, and a row stamped when the read began is off the chip's own sample
    instant by however late the read was: on a real clock, a loop that falls behind (a loaded host, a slow bus or
    table link). Either puts a move's integrated angle off by the rate's change times the time error (in the
    mixed rig at load 5 on 2 cores: 1-7 samples lost a move, stamps 17 ms before to 7 ms after the chip's sample
    instants, moves off by up to 0.5 %), which no sample model of the integration can take back."""
    dt = np.concatenate([np.diff(m.t) for m in moves])
    turned = np.degrees(np.concatenate(rotation_steps(moves, B, H)))
    period = float(np.median(dt))
    hole = dt > HOLE_PERIODS * period
    lost = hole & (turned > HOLE_TURN_DEG)
    regular = dt[~hole]
    return MoveTiming(period, int(np.sum(np.round(dt[lost] / period) - 1)), int(lost.sum()),
                      float(dt[lost].max()) if lost.any() else 0.0, float(turned[lost].max()) if lost.any() else 0.0,
                      float(np.sqrt(np.mean((regular - period) ** 2))) if regular.size else 0.0)
