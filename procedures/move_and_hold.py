"""The calibration session: move, verify arrival and settle, hold and record, repeat; moves recorded too.

Every hold is committed to the store in its own transaction before the table moves on, so a crash loses
at most the hold in progress, and `resume` continues from the next orientation. A step whose data cannot be
used as recorded is redone rather than stored or dropped: a hold that moved (a knock), a chip that reset to its
power-on registers (its configuration is read back before each hold is stored; it is configured again), a gyro
stream with a hole in the move (a read error, a retried table request). The rig goes back to the previous
orientation, holds there again and records the move and the hold again, so the gyro keeps every move whole.
The table is always left safe (stopped, disabled) whatever happens, by the caller's `finally`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from drivers.contract import KeepsConfiguration
from drivers.errors import DriverError
from procedures.acquisition import Recording, Sampler, grid_rate_hz, log_read_errors
from procedures.hold_quality import HoldTarget, hold_has_motion, log_outliers
from rig.schedule import Orientation
from procedures.protocols import Board, Store, Table
from procedures.reference import interpolate_angles
from procedures.slots import triad_kind
from rig.clock import Clock
from rig.config import ScheduleConfig, TurntableConfig
from rig.errors import RigError
from rig.rotations import TableGeometry, quat_from_matrix

Progress = Callable[[int, int, str], None]


@dataclass(frozen=True)
class MotionSettings:
    """How the table moves and each hold is recorded: the configuration's [turntable] and [schedule] as they are,
    and, for sequential holds, what ends each (`procedures.hold_quality.HoldTarget`)."""

    table: TurntableConfig
    schedule: ScheduleConfig
    sequential: HoldTarget | None = None


HOLD_POLL_S = 0.5   # encoder reads during a hold: within any sane comms watchdog, cheap on the bus
SEQUENTIAL_CHECK_S = 0.1   # how often a sequential hold asks whether it has what it needs


class HoldFailed(RigError, RuntimeError):
    """A hold kept moving in every allowed attempt: the table or its surroundings are not still."""


def arm_table(table: Table, m: MotionSettings) -> None:
    """Enable the servos with the table's comms watchdog armed: if this host dies mid-session, the table
    stops by itself within `watchdog_ms` (the rig polls well inside that; make_safe disarms it)."""
    if m.table.watchdog_ms:
        table.set_watchdog(int(m.table.watchdog_ms))
    table.enable()


def position_table(table: Table, clock: Clock, target: Orientation, m: MotionSettings) -> None:
    """An unrecorded move (to the start, or back to the last hold on resume)."""
    table.move_to(target.outer_deg, target.inner_deg, speed_dps=m.table.speed_dps, accel_dps2=m.table.accel_dps2,
                  tolerance_deg=m.table.tolerance_deg, settle_s=m.table.settle_s)


def run_session(table: Table, board: Board, clock: Clock, store: Store, schedule: list[Orientation],
                geometry: TableGeometry, m: MotionSettings, *, start_step: int = 0, session_t0: float = 0.0,
                progress: Progress | None = None) -> dict:
    """Record holds `start_step..` of `schedule` and the moves between them into `store`.

    The table is positioned straight at orientation `start_step` (an unrecorded move) and its hold is the
    first thing recorded: a resumed run starts by holding again where the interrupted one last held, so the
    first recorded move starts from a hold of its own run, never across the interruption.
    Returns acquisition figures: ticks on the grid (`ticks`), those the loop fell behind on (`skipped_ticks`),
    those read in a step that was spoiled and redone, not stored (`ticks_discarded`), and reads that found no
    fresh sample (`late_reads`): every tick is a stored row or counted in one of the first two.
    """
    n = len(schedule)
    arm_table(table, m)
    if progress:
        progress(start_step, n, "positioning")
    position_table(table, clock, schedule[start_step], m)
    sampler = Sampler(board, clock, grid_rate_hz(board, m.schedule.rate_hz), m.schedule.mag_every,
                      session_t0=session_t0)
    sampler.align_to("gyro")
    j, first, tries = start_step, start_step, {}
    stored, discarded = sampler.taken_rows, 0        # rows taken up to the last stored step; rows thrown away
    at = None       # the encoder angles read last, when the table has not moved since (a step's end: its start)
    while j < n:
        attempt = tries.get(j, 0) + 1
        try:
            if j > first:
                if progress:
                    progress(j, n, "move")
                at = _record_move(table, sampler, store, geometry, schedule[j], j - 1, m,
                                  strict=attempt < m.schedule.max_hold_attempts, start_deg=at)
                stored = sampler.taken_rows
            if progress:
                progress(j, n, "hold")
            at = _record_hold(table, sampler, board, store, geometry, schedule[j], j, m, attempt, start_deg=at)
            stored = sampler.taken_rows
            j += 1
        except StepSpoiled as spoiled:
            discarded += sampler.taken_rows - stored
            stored = sampler.taken_rows
            tries[j] = attempt
            at = None
            if attempt >= m.schedule.max_hold_attempts:
                raise spoiled.final(j, attempt) from None
            j = _redo(table, store, sampler, schedule, j, first, spoiled, m)
            first = j
    if progress:
        progress(n, n, "done")
    return {"ticks": sampler._k, "late_reads": sampler.late_reads, "skipped_ticks": sampler.skipped_ticks,
            "ticks_discarded": discarded, "steps_redone": sum(tries.values())}


class StepSpoiled(RigError):
    """The move into hold j or hold j cannot be used as recorded (the hold moved, a chip lost its configuration,
    the gyro missed part of the move): the step is redone. `restart`: chips to configure again first."""

    def __init__(self, message: str, restart: list | None = None) -> None:
        self.restart = list(restart or [])
        super().__init__(message)

    def final(self, step: int, attempts: int) -> RigError:
        """What to raise when the step was spoiled in every allowed attempt."""
        return ConfigurationLost(f"{self}; hold {step}: the same in all {attempts} attempts, the chip keeps "
                                 "resetting")


class HoldMoved(StepSpoiled):
    def final(self, step: int, attempts: int) -> RigError:
        return HoldFailed(f"hold {step} kept moving in all {attempts} attempts (see the session's hold-repeated "
                          f"events); nothing of it was stored, so `rig resume` retries it")


class ConfigurationLost(RigError):
    """A chip keeps losing its configuration (or it cannot be read back): the session cannot go on."""


def check_configuration(board: Board) -> None:
    """Raise StepSpoiled if a part reset to its power-on registers since it was started (or if its registers
    cannot be read back now: a bus glitch or a reset, the step is not trusted either way)."""
    lost, messages = [], []
    for part in board.parts:
        if not isinstance(part, KeepsConfiguration):
            continue
        try:
            why = part.configuration_lost()
        except DriverError as exc:
            messages.append(f"its configuration could not be read back: {exc}")
            continue
        if why is not None:
            lost.append(part)
            messages.append(why)
    if messages:
        raise StepSpoiled("; ".join(messages) + ("; configured again" if lost else ""), restart=lost)


def _redo(table: Table, store: Store, sampler: Sampler, schedule: list[Orientation], j: int, first: int,
          spoiled: StepSpoiled, m: MotionSettings) -> int:
    """Redo step j: configure again the chips that lost their configuration, and record again from hold j-1
    held again, so the move into hold j is recorded whole, from a hold of its own (the first hold of a run
    is simply held again). Nothing of the spoiled move or hold is stored. Returns the step to record from."""
    for part in spoiled.restart:
        part.start()
    if j == first:
        return j
    position_table(table, sampler.clock, schedule[j - 1], m)
    store.redo(sampler.stamp(sampler.clock.now()), f"before hold {j} was stored: {spoiled}; step {j} redone "
               f"from hold {j - 1} held again")
    return j - 1


def _record_move(table: Table, sampler: Sampler, store: Store, geometry: TableGeometry, target: Orientation,
                 step: int, m: MotionSettings, strict: bool = True,
                 start_deg: tuple[float, float] | None = None) -> tuple[float, float]:
    """Record the move leaving hold `step`; returns the encoder angles at its end. `strict`: a move whose gyro
    stream has a hole while the table turns (a read error, a retried table request: `gyro_hole`) spoils the step.
    `start_deg`: the angles the hold just read (the table has not moved since), else they are read here."""
    t_pos = [sampler.stamp(sampler.clock.now())]
    pos, vel = [table.positions() if start_deg is None else start_deg], [(0.0, 0.0)]

    def log_polls(statuses: list) -> None:
        ordered = sorted(statuses, key=lambda st: st.axis)
        t_pos.append(sampler.stamp(sampler.clock.now()))
        pos.append(tuple(st.position_deg for st in ordered))
        vel.append(tuple(st.velocity_dps for st in ordered))

    final = table.move_to(target.outer_deg, target.inner_deg, speed_dps=m.table.speed_dps,
                          accel_dps2=m.table.accel_dps2, tolerance_deg=m.table.tolerance_deg,
                          settle_s=m.table.settle_s, on_poll=log_polls,
                          wait=sampler.run_for)
    rec = sampler.take()
    t_pos.append(sampler.stamp(sampler.clock.now()))
    pos.append(_angles(final) if final else table.positions())      # its last poll read them as it ended
    vel.append((0.0, 0.0))
    table_deg = interpolate_angles(rec.t, t_pos, pos, vel)
    log_read_errors(store, sampler)
    hole = gyro_hole(rec, table_deg, sampler.dt, m.table.tolerance_deg, skip=sampler.gone)
    if strict and hole is not None:
        raise StepSpoiled(f"the gyro has no samples for {hole[0]:.3f} s of the move into hold {step + 1} while the "
                          f"table turned {hole[1]:.2f} deg (read errors or a retried table request)")
    store.append_move(step, t=rec.t, samples=rec.samples, q_ref=quat_from_matrix(geometry.rotation(*table_deg.T)),
                      table_deg=table_deg, temp_c=rec.temp_c, vsupply_v=rec.vsupply_v)
    return pos[-1]


def _angles(statuses: list) -> tuple[float, float]:
    """(outer, inner) encoder angles of one status poll of both axes."""
    return tuple(st.position_deg for st in sorted(statuses, key=lambda st: st.axis))


def gyro_hole(rec: Recording, table_deg: np.ndarray, dt: float, tolerance_deg: float,
              skip=frozenset()) -> tuple[float, float] | None:
    """(seconds, degrees) of the worst hole in a move's gyro streams (every slot's, but those in `skip`: dropped),
    counted from the hold it leaves to the hold it reaches, across which the table turned more than
    `tolerance_deg`; None if there is none.

    No interpolation knows the rate inside a hole: where the rate profile has a corner in it (the start or end
    of a turn, usually) the move's angle is off by up to a/8 h^2, at 360 deg/s^2 and 0.05 s already 0.1 deg."""
    worst = None
    for name in [n for n in rec.samples if triad_kind(n) == "gyro" and n not in skip]:
        if rec.t.size == 0:
            return None
        have = np.flatnonzero(~np.isnan(rec.samples[name]).any(axis=1))
        t = np.concatenate([[rec.t[0] - dt], rec.t[have], [rec.t[-1] + dt]])
        angles = np.vstack([table_deg[:1], table_deg[have], table_deg[-1:]])
        gaps, turned = np.diff(t), np.linalg.norm(np.diff(angles, axis=0), axis=1)
        holes = np.flatnonzero((gaps > 1.5 * dt) & (turned > tolerance_deg))
        if holes.size:
            k = holes[np.argmax(turned[holes])]
            if worst is None or turned[k] > worst[1]:
                worst = (float(gaps[k]), float(turned[k]))
    return worst


def _record_hold(table: Table, sampler: Sampler, board: Board, store: Store, geometry: TableGeometry,
                 target: Orientation, step: int, m: MotionSettings, attempt: int = 1,
                 start_deg: tuple[float, float] | None = None) -> tuple[float, float]:
    """Record one attempt at hold `step`; stored unless the chips lost their configuration or the hold moved.
    `start_deg`: the angles the move into it read as it ended, else read here. Returns the last angles read."""
    sequential = m.sequential is not None and bool(m.sequential.target)   # the first hold of a run: hold_s
    rate_hz = sampler.rate_hz
    ticks = int(round((m.sequential.max_s if sequential else m.schedule.hold_s) * rate_hz))
    chunk = max(int(round(HOLD_POLL_S * rate_hz)), 1)
    every = max(int(round(SEQUENTIAL_CHECK_S * rate_hz)), 1) if sequential else chunk
    readings = [table.positions() if start_deg is None else start_deg]
    for k in range(every, ticks + every, every):
        done = min(k, ticks)
        sampler.run(done - (k - every))
        ended = done >= ticks or (sequential and m.sequential.done(sampler.so_far(), done / rate_hz))
        if ended or done % chunk == 0:
            readings.append(table.positions())  # encoder log, and a keep-alive for the table's watchdog
        if ended:
            break
    rec = sampler.take()
    log_read_errors(store, sampler)
    check_configuration(board)
    moved = hold_has_motion(rec, rate_hz=rate_hz)
    drift = float(np.ptp(np.asarray(readings), axis=0).max())
    if drift > m.table.tolerance_deg:
        moved = f"encoders moved {drift:.4f} deg during the hold"
    if moved is not None:
        store.log_event("hold-repeated", f"hold {step} attempt {attempt}: {moved}", float(rec.t[-1]))
        raise HoldMoved(f"hold {step} moved ({moved})")
    measured = tuple(float(v) for v in np.mean(readings, axis=0))
    table_deg = np.tile(measured, (rec.t.size, 1))
    q = quat_from_matrix(geometry.rotation(*measured))
    store.append_hold(step, t=rec.t, samples=rec.samples, q_ref=np.tile(q, (rec.t.size, 1)),
                      table_deg=table_deg, commanded_deg=(target.outer_deg, target.inner_deg),
                      measured_deg=measured, temp_c=rec.temp_c, vsupply_v=rec.vsupply_v, attempt=attempt)
    log_outliers(store, step, rec)
    if m.sequential is not None:
        m.sequential.learn(rec.samples)
    return readings[-1]
