"""The calibration session: move, verify arrival and settle, hold and record, repeat; moves recorded too.

Every hold is committed to the store in its own transaction before the table moves on, so a crash loses
at most the hold in progress, and `resume` continues from the next orientation. Before a hold is stored the
chips' configuration registers are read back: a chip that reset to its power-on registers (a brown-out) is
configured again and the step redone, so no sample it gave unconfigured is stored. The table is always
left safe (stopped, disabled) whatever happens, by the caller's `finally` around `run_session`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from drivers.contract import KeepsConfiguration
from procedures.acquisition import Recording, Sampler, hold_has_motion, log_outliers, log_read_errors
from procedures.planning import Orientation
from procedures.protocols import Board, Store, Table
from procedures.reference import interpolate_angles
from rig.clock import Clock
from rig.errors import RigError
from rig.rotations import TableGeometry, quat_from_matrix

Progress = Callable[[int, int, str], None]


@dataclass
class MotionSettings:
    speed_dps: float = 60.0
    accel_dps2: float = 120.0
    tolerance_deg: float = 0.01
    settle_s: float = 0.3
    poll_every: int = 10
    hold_s: float = 5.0
    rate_hz: float = 100.0
    mag_every: int = 2
    max_hold_attempts: int = 3
    watchdog_ms: int = 2000


HOLD_POLL_S = 0.5   # encoder reads during a hold: within any sane comms watchdog, cheap on the bus


class HoldFailed(RigError, RuntimeError):
    """A hold kept moving in every allowed attempt: the table or its surroundings are not still."""


def arm_table(table: Table, m: MotionSettings) -> None:
    """Enable the servos with the table's comms watchdog armed: if this host dies mid-session, the table
    stops by itself within `watchdog_ms` (the rig polls well inside that; make_safe disarms it)."""
    if m.watchdog_ms:
        table.set_watchdog(int(m.watchdog_ms))
    table.enable()


def position_table(table: Table, clock: Clock, target: Orientation, m: MotionSettings) -> None:
    """An unrecorded move (to the start, or back to the last hold on resume)."""
    table.move_to(target.outer_deg, target.inner_deg, speed_dps=m.speed_dps, accel_dps2=m.accel_dps2,
                  tolerance_deg=m.tolerance_deg, settle_s=m.settle_s)


def run_session(table: Table, board: Board, clock: Clock, store: Store, schedule: list[Orientation],
                geometry: TableGeometry, m: MotionSettings, *, start_step: int = 0, session_t0: float = 0.0,
                progress: Progress | None = None) -> dict:
    """Record holds `start_step..` of `schedule` and the moves between them into `store`.

    The table is positioned straight at orientation `start_step` (an unrecorded move) and its hold is the
    first thing recorded: a resumed run starts by holding again where the interrupted one last held, so the
    first recorded move starts from a hold of its own run, never across the interruption.
    Returns acquisition figures: ticks sampled and reads that found no fresh sample (late_reads).
    """
    n = len(schedule)
    arm_table(table, m)
    if progress:
        progress(start_step, n, "positioning")
    position_table(table, clock, schedule[start_step], m)
    sampler = Sampler(board, clock, m.rate_hz, m.mag_every, session_t0=session_t0)
    sampler.align_to("gyro")
    j, first, redone = start_step, start_step, {}
    while j < n:
        try:
            if j > first:
                if progress:
                    progress(j, n, "move")
                _record_move(table, sampler, store, geometry, schedule[j], j - 1, m)
            if progress:
                progress(j, n, "hold")
            _record_hold(table, sampler, board, store, geometry, schedule[j], j, m)
            j += 1
        except ConfigurationLost as lost:
            redone[j] = redone.get(j, 0) + 1
            if redone[j] >= m.max_hold_attempts:
                lost.add_note(f"hold {j}: a chip lost its configuration in {redone[j]} attempts; it keeps resetting")
                raise
            j = _redo_after_reset(table, board, store, sampler, schedule, j, first, lost, m)
            first = j
    if progress:
        progress(n, n, "done")
    return {"ticks": sampler._k, "late_reads": sampler.late_reads, "skipped_ticks": sampler.skipped_ticks,
            "chip_resets": sum(redone.values())}


class ConfigurationLost(RigError):
    """A chip no longer holds its configuration (a power-on reset mid-session); `parts` lost it."""

    def __init__(self, parts: list, messages: list[str]) -> None:
        self.parts = parts
        super().__init__("; ".join(messages))


def check_configuration(board: Board) -> None:
    """Raise ConfigurationLost if a part reset to its power-on registers since it was started."""
    lost = [(part, part.configuration_lost()) for part in board.parts if isinstance(part, KeepsConfiguration)]
    lost = [(part, why) for part, why in lost if why is not None]
    if lost:
        raise ConfigurationLost([part for part, _ in lost], [why for _, why in lost])


def _redo_after_reset(table: Table, board: Board, store: Store, sampler: Sampler, schedule: list[Orientation],
                      j: int, first: int, lost: ConfigurationLost, m: MotionSettings) -> int:
    """A chip reset since hold j-1 was checked and stored: configure it again and redo the step, from hold j-1
    held again (so the move into hold j is recorded again, whole, from a hold of its own). Returns the step
    to record from. Nothing of the spoiled move or hold is stored."""
    for part in lost.parts:
        part.start()
    back = j - 1 if j > first else j
    position_table(table, sampler.clock, schedule[back], m)
    store.redo(sampler.stamp(sampler.clock.now()), f"chip reset before hold {j} was stored: {lost}; configured "
               f"again, " + (f"step {j} redone from hold {back} held again" if back < j else f"hold {j} redone"))
    return back


def _record_move(table: Table, sampler: Sampler, store: Store, geometry: TableGeometry, target: Orientation,
                 step: int, m: MotionSettings) -> None:
    t_pos, pos, vel = [sampler.stamp(sampler.clock.now())], [table.positions()], [(0.0, 0.0)]

    def log_polls(statuses: list) -> None:
        ordered = sorted(statuses, key=lambda st: st.axis)
        t_pos.append(sampler.stamp(sampler.clock.now()))
        pos.append(tuple(st.position_deg for st in ordered))
        vel.append(tuple(st.velocity_dps for st in ordered))

    table.move_to(target.outer_deg, target.inner_deg, speed_dps=m.speed_dps, accel_dps2=m.accel_dps2,
                  tolerance_deg=m.tolerance_deg, settle_s=m.settle_s, on_poll=log_polls, wait=sampler.run_for)
    rec = sampler.take()
    t_pos.append(sampler.stamp(sampler.clock.now()))
    pos.append(table.positions())
    vel.append((0.0, 0.0))
    table_deg = interpolate_angles(rec.t, t_pos, pos, vel)
    store.append_move(step, t=rec.t, samples=rec.samples, q_ref=quat_from_matrix(geometry.rotation(*table_deg.T)),
                      table_deg=table_deg, temp_c=rec.temp_c, vsupply_v=rec.vsupply_v)
    log_read_errors(store, sampler)


def _record_hold(table: Table, sampler: Sampler, board: Board, store: Store, geometry: TableGeometry,
                 target: Orientation, step: int, m: MotionSettings) -> Recording:
    ticks = int(round(m.hold_s * m.rate_hz))
    chunk = max(int(round(HOLD_POLL_S * m.rate_hz)), 1)
    for attempt in range(1, m.max_hold_attempts + 1):
        readings = [table.positions()]
        for k in range(0, ticks, chunk):
            sampler.run(min(chunk, ticks - k))
            readings.append(table.positions())      # encoder log, and a keep-alive for the table's watchdog
        rec = sampler.take()
        check_configuration(board)
        moved = hold_has_motion(rec, rate_hz=m.rate_hz)
        drift = float(np.ptp(np.asarray(readings), axis=0).max())
        if drift > m.tolerance_deg:
            moved = f"encoders moved {drift:.4f} deg during the hold"
        if moved is None:
            measured = tuple(float(v) for v in np.mean(readings, axis=0))
            table_deg = np.tile(measured, (rec.t.size, 1))
            q = quat_from_matrix(geometry.rotation(*measured))
            store.append_hold(step, t=rec.t, samples=rec.samples, q_ref=np.tile(q, (rec.t.size, 1)),
                              table_deg=table_deg, commanded_deg=(target.outer_deg, target.inner_deg),
                              measured_deg=measured, temp_c=rec.temp_c, vsupply_v=rec.vsupply_v, attempt=attempt)
            log_read_errors(store, sampler)
            log_outliers(store, step, rec)
            return rec
        store.log_event("hold-repeated", f"hold {step} attempt {attempt}: {moved}", float(rec.t[-1]))
    raise HoldFailed(f"hold {step} kept moving in all {m.max_hold_attempts} attempts (see the session's "
                     f"hold-repeated events); nothing of it was stored, so `rig resume` retries it")
