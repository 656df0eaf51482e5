"""`TurntableLink`: drive a two-axis Modbus turntable by its register-map profile.

All waiting (poll intervals, settle, timeouts, retry backoff) goes through the injected clock, so with a
simulated clock and the fake turntable a 100 s move runs in a fraction of a second.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from pathlib import Path

from rig.clock import Clock, RealClock
from rig.modbus.channel import ModbusChannel
from rig.modbus.device import ModbusDevice
from rig.turntable.errors import (LINK_ERRORS, CommunicationError, EStopActive, IdentityError,
                                  ModbusExceptionError, MoveRejected, MoveTimeout, ResponseLost, TableAlarm,
                                  TurntableError)
from rig.turntable.profile import AXIS_REGISTER_TYPES, TableProfile, decode_bits, load_profile
from rig.turntable.status import AxisStatus, TableStatus, decode_axis, int_to_words, words_to_int
from rig.trapezoid import trapezoid
from rig.turntable.url import parse_url

log = logging.getLogger(__name__)

Goal = Callable[[AxisStatus], bool]
PollHook = Callable[[Sequence[AxisStatus]], None]
SEQ_MASK = 0xFFFF


def profile_time(distance: float, speed: float, accel: float, decel: float) -> float:
    """Duration of a trapezoidal (or, if short, triangular) move from rest to rest."""
    return trapezoid(distance, speed, accel, decel).duration


class TurntableLink(ModbusDevice):
    """A context manager around one turntable; leaving the `with` block always makes the table safe."""

    def __init__(self, url: str, profile: TableProfile | str | Path | None = None, clock: Clock | None = None,
                 timeout: float = 1.0, retries: int = 3, poll_interval: float = 0.05,
                 device_id: int | None = None) -> None:
        self.profile = profile if isinstance(profile, TableProfile) else load_profile(profile)
        self.url = url
        self.clock: Clock = clock if clock is not None else RealClock()
        if not poll_interval > 0:
            raise ValueError(f"poll_interval must be positive, got {poll_interval}")
        self.poll_interval = poll_interval
        self.retries = retries
        self.device_id = self.profile.device_id if device_id is None else device_id
        self.channel = ModbusChannel(parse_url(url), self.device_id, self.clock, timeout, retries,
                                     device="turntable", errors=LINK_ERRORS)
        self.axes = tuple(range(len(self.profile.axis_bases)))

    # ---- reading ----------------------------------------------------------------------------------
    def identify(self) -> tuple[int, int]:
        """(DEVICE_ID, MAP_VERSION), checked against the profile."""
        g = self._read_globals(("DEVICE_ID", "MAP_VERSION"))
        p = self.profile
        if g["DEVICE_ID"] != p.expected_device_id:
            raise IdentityError(f"{self.url}: DEVICE_ID register reads 0x{g['DEVICE_ID']:04X}, profile {p.path} "
                                f"expects 0x{p.expected_device_id:04X}: not a turntable speaking {p.name}")
        if g["MAP_VERSION"] >> 8 != p.expected_map_version >> 8:
            raise IdentityError(f"{self.url}: MAP_VERSION 0x{g['MAP_VERSION']:04X} has another major version "
                                f"than 0x{p.expected_map_version:04X} of profile {p.path}")
        return g["DEVICE_ID"], g["MAP_VERSION"]

    def axis_status(self, axis: int | str) -> AxisStatus:
        """One FC03 of the axis's feedback block (+0x10..+0x1B in the default map)."""
        axis = self.profile.axis_index(axis)
        start, count = self.profile.feedback_block()
        words = self.channel.read(self.profile.axis_bases[axis] + start, count, f"axis {axis} feedback")
        return decode_axis(self.profile, axis, words)

    def status(self) -> TableStatus:
        g = self._read_globals(("SYS_STATUS", "HEARTBEAT"))
        return TableStatus(axes=tuple(self.axis_status(a) for a in self.axes),
                           sys_status_word=g["SYS_STATUS"],
                           sys_flags=decode_bits(g["SYS_STATUS"], self.profile.sys_status_bits),
                           heartbeat=g["HEARTBEAT"])

    def positions(self) -> tuple[float, float]:
        """(outer, inner) encoder angles in degrees: two 2-register reads, cheap enough for logging."""
        return tuple(self._read_axis_value(a, "ACTUAL_POS") / self.profile.units_per_degree for a in self.axes)

    # ---- power and safety -------------------------------------------------------------------------
    def enable(self) -> None:
        for a in self.axes:
            self._write_axis_idempotent(a, "ENABLE", 1)

    def disable(self) -> None:
        for a in self.axes:
            self._write_axis_idempotent(a, "ENABLE", 0)

    def estop(self) -> None:
        """Software e-stop of both axes (latching). Not a substitute for the hard-wired e-stop."""
        self._write_global("SYS_COMMAND", self.profile.sys_commands["ESTOP"])

    def reset(self) -> None:
        """Reset the e-stop latch and alarms; raises if either is still present afterwards."""
        self._write_global("SYS_COMMAND", self.profile.sys_commands["RESET"])
        st = self.status()
        if "ESTOP" in st.sys_flags:
            raise EStopActive(f"{self.url}: e-stop still latched after reset (hard-wired e-stop engaged?)")
        alarms = [a for a in st.axes if a.has("ALARM") or a.alarm_code]
        if alarms or "ALARM" in st.sys_flags:
            detail = "; ".join(f"axis {a.axis} ({a.name}) ALARM_CODE={a.alarm}" for a in alarms) or "SYS_STATUS"
            raise TableAlarm(f"{self.url}: alarm persists after reset: {detail}",
                             axis=alarms[0].axis if alarms else None, alarm=alarms[0].alarm if alarms else "")

    def set_watchdog(self, ms: int) -> None:
        """0 turns it off; otherwise no request within `ms` makes the table stop both axes (alarm 5)."""
        if isinstance(ms, bool) or not isinstance(ms, int) or not 0 <= ms <= 0xFFFF:
            raise ValueError(f"WATCHDOG_MS must be an integer in 0..65535, got {ms!r}")
        self._write_global("WATCHDOG_MS", ms)

    def stop(self) -> None:
        """Both axes decelerate to a stop. A STOP refused by an axis that is not moving is fine."""
        for a in self.axes:
            try:
                self._write_axis_idempotent(a, "COMMAND", self.profile.commands["STOP"])
            except ModbusExceptionError:
                if self.axis_status(a).has("MOVING"):
                    raise

    def make_safe(self, standstill_timeout: float = 10.0) -> None:
        """Stop, wait for standstill within a bound, disable, disarm the watchdog. Never raises: it runs in
        `finally` paths.

        If the link itself is down the remaining steps are skipped (each would only wait out its
        retries); the table's own WATCHDOG_MS, if set, is what stops it then.
        """
        if not self.channel.is_open:
            return
        steps = (("stop", self.stop), ("wait for standstill", lambda: self._wait_standstill(standstill_timeout)),
                 ("disable", self.disable), ("disarm the comms watchdog", lambda: self.set_watchdog(0)))
        for step, action in steps:
            try:
                action()
            except CommunicationError as exc:
                log.error("turntable make_safe: %s failed, link down, table state unknown: %s", step, exc)
                return
            except Exception as exc:  # noqa: BLE001 - make_safe must carry on to disable
                log.error("turntable make_safe: %s failed: %s", step, exc)

    # ---- motion -----------------------------------------------------------------------------------
    def move_to(self, outer_deg: float, inner_deg: float, speed_dps: float = 30.0, accel_dps2: float = 60.0,
                tolerance_deg: float = 0.01, settle_s: float = 0.2, timeout: float | None = None,
                decel_dps2: float | None = None, on_poll: PollHook | None = None,
                wait: Callable[[float], None] | None = None) -> list[AxisStatus]:
        """Move both axes together to absolute angles and return once both are in position and settled.

        Follows the map's move protocol: FC16 TARGET_POS/TARGET_VEL/ACCEL/DECEL, FC06 COMMAND=MOVE_ABS,
        then poll until CMD_SEQ advanced past its value before the command, IN_POSITION and
        |ACTUAL_POS - target| <= tolerance, for `settle_s`. The default timeout is 1.5 x the longer
        axis's trapezoid time + settle + 2 s. On any failure the table is stopped. Returns the axes'
        status at the end of the settle time; `on_poll` sees every poll (for logging encoder angles);
        `wait(dt)` replaces the clock's sleep between polls (a procedure samples its sensors there).
        """
        targets = (float(outer_deg), float(inner_deg))
        decel = accel_dps2 if decel_dps2 is None else decel_dps2
        _check_positive(speed_dps=speed_dps, accel_dps2=accel_dps2, decel_dps2=decel, tolerance_deg=tolerance_deg)
        _check_finite(outer_deg=outer_deg, inner_deg=inner_deg)
        if not (math.isfinite(settle_s) and settle_s >= 0):
            raise ValueError(f"settle_s must be >= 0, got {settle_s!r}")
        scale = self.profile.units_per_degree
        with self._stop_on_failure():
            before = self._check_can_move()
            expected = max(profile_time(t - b.position_deg, speed_dps, accel_dps2, decel)
                           for t, b in zip(targets, before))
            if timeout is None:
                timeout = 1.5 * expected + settle_s + 2.0 + 4 * self.poll_interval
            for a, target in zip(self.axes, targets):
                self._write_axis_block(a, {"TARGET_POS": round(target * scale), "TARGET_VEL": round(speed_dps * scale),
                                           "ACCEL": round(accel_dps2 * scale), "DECEL": round(decel * scale)})
            deadline = self.clock.now() + timeout
            for a in self.axes:
                self._command(a, "MOVE_ABS", before[a].cmd_seq)

            def arrived(st: AxisStatus) -> bool:
                return st.has("IN_POSITION") and abs(st.position_deg - targets[st.axis]) <= tolerance_deg

            return self._wait(before, arrived, deadline, timeout, settle_s, on_poll, wait,
                              lambda a: f"{targets[a]:.4f} deg (+-{tolerance_deg} deg)",
                              expected_end=self.clock.now() + expected)

    def home(self, timeout: float = 120.0, speed_dps: float = 10.0, accel_dps2: float = 20.0,
             on_poll: PollHook | None = None) -> None:
        """Home both axes together; returns once both report HOMED and have stopped.

        The homing speed is written first (TARGET_VEL/ACCEL/DECEL) so homing never runs at whatever
        profile the previous move left behind.
        """
        _check_positive(speed_dps=speed_dps, accel_dps2=accel_dps2, timeout=timeout)
        scale = self.profile.units_per_degree
        with self._stop_on_failure():
            before = self._check_can_move()
            for a in self.axes:
                self._write_axis_block(a, {"TARGET_VEL": round(speed_dps * scale), "ACCEL": round(accel_dps2 * scale),
                                           "DECEL": round(accel_dps2 * scale)})
            deadline = self.clock.now() + timeout
            for a in self.axes:
                self._command(a, "HOME", before[a].cmd_seq)

            def homed(st: AxisStatus) -> bool:
                return st.has("HOMED") and not st.has("HOMING") and not st.has("MOVING")

            self._wait(before, homed, deadline, timeout, 0.0, on_poll, None, lambda a: "HOMED")

    def move_velocity(self, axis: int | str, rate_dps: float, accel_dps2: float) -> None:
        """Rate mode: the axis ramps to `rate_dps` (signed) and keeps turning until `stop()`.

        Returns once the table accepted the command (CMD_SEQ advanced), not when the rate is reached.
        """
        axis = self.profile.axis_index(axis)
        _check_finite(rate_dps=rate_dps)
        _check_positive(accel_dps2=accel_dps2)
        scale = self.profile.units_per_degree
        with self._stop_on_failure():
            before = self._check_can_move()
            self._write_axis_block(axis, {"TARGET_VEL": round(rate_dps * scale), "ACCEL": round(accel_dps2 * scale),
                                          "DECEL": round(accel_dps2 * scale)})
            self._command(axis, "MOVE_VEL", before[axis].cmd_seq)

    # ---- protocol internals -----------------------------------------------------------------------
    def _check_can_move(self) -> list[AxisStatus]:
        """Read both axes (this is also the CMD_SEQ 'before the command'); refuse under e-stop or alarm."""
        sts = [self.axis_status(a) for a in self.axes]
        for st in sts:
            self._raise_on_fault(st)
        return sts

    def _raise_on_fault(self, st: AxisStatus) -> None:
        if st.has("ESTOP"):
            raise EStopActive(f"{self.url}: e-stop latched; {st.describe()}; call reset()")
        if st.has("ALARM") or st.alarm_code:
            raise TableAlarm(f"{self.url}: alarm {st.alarm}; {st.describe()}", axis=st.axis, alarm=st.alarm)

    def _wait(self, before: list[AxisStatus], goal: Goal, deadline: float, timeout: float, settle_s: float,
              on_poll: PollHook | None, wait: Callable[[float], None] | None,
              describe_goal: Callable[[int], str], expected_end: float | None = None) -> list[AxisStatus]:
        """Poll every axis once per interval until each accepted its command and meets `goal` for `settle_s`.

        Without a `wait` (nobody samples during the move), polls are spaced out while the profile says
        arrival is far off (half the time left, at most 0.5 s): a long move then costs a few requests, not
        one per interval, on the bus and on a simulated clock.
        """
        seq0 = {b.axis: b.cmd_seq for b in before}
        accepted = {a: False for a in seq0}
        since: float | None = None
        while True:
            sts = [self.axis_status(a) for a in seq0]
            if on_poll is not None:
                on_poll(sts)
            for st in sts:
                accepted[st.axis] = accepted[st.axis] or (st.cmd_seq - seq0[st.axis]) & SEQ_MASK != 0
                self._raise_on_fault(st)
                if accepted[st.axis] and not st.has("ENABLED"):
                    raise TurntableError(f"{self.url}: axis {st.axis} ({st.name}) lost ENABLED during the "
                                         f"command; {st.describe()}")
            now = self.clock.now()
            if all(accepted[st.axis] and goal(st) for st in sts):
                since = now if since is None else since
                if now - since >= settle_s:
                    return sts
            else:
                since = None
                if now >= deadline:
                    late = next(st for st in sts if not (accepted[st.axis] and goal(st)))
                    goal_text = describe_goal(late.axis) if accepted[late.axis] else "CMD_SEQ advance (command accepted)"
                    raise MoveTimeout(late.axis, late.name, goal_text, late.position_deg, late.flags, late.alarm,
                                      timeout)
            if wait is not None:
                wait(self.poll_interval)
            else:
                left = 0.0 if expected_end is None else expected_end - now
                self.clock.sleep(max(self.poll_interval, min(0.5, 0.5 * left)))

    def _command(self, axis: int, name: str, seq_before: int) -> None:
        """FC06 COMMAND. A lost response is resolved by reading CMD_SEQ: advanced means accepted; unchanged
        means the table never acted on it, so it is safe to send again."""
        code = self.profile.commands[name]
        address = self.profile.addr(axis, "COMMAND")
        label = f"axis {axis} COMMAND={name}"
        for attempt in range(self.retries + 1):
            try:
                self.channel.write(address, [code], label, idempotent=False)
                return
            except ModbusExceptionError as exc:
                raise self._rejection(axis, name, exc) from exc
            except ResponseLost as exc:
                seq = self.axis_status(axis).cmd_seq
                if (seq - seq_before) & SEQ_MASK:
                    log.warning("turntable: %s: response lost but CMD_SEQ %d -> %d: accepted", label, seq_before, seq)
                    return
                log.warning("turntable: %s: response lost, CMD_SEQ unchanged (%d): not executed, re-sending (%s)",
                            label, seq, exc)
                self.channel.backoff(attempt, label)
        raise CommunicationError(f"{self.url}: {label}: no response after {self.retries + 1} attempts "
                                 f"and CMD_SEQ never advanced")

    def _rejection(self, axis: int, command: str, exc: ModbusExceptionError) -> TurntableError:
        try:
            st = self.axis_status(axis)
        except TurntableError as read_exc:
            return MoveRejected(axis, self.profile.axis_names[axis], command, f"unknown ({read_exc})", exc)
        rejected = MoveRejected(axis, st.name, command, st.last_error, exc)
        if st.has("ESTOP"):
            return EStopActive(f"{self.url}: e-stop latched: {rejected}; call reset()")
        return rejected

    def _stop_on_failure(self):
        return _StopOnFailure(self)

    def _stop_quietly(self) -> None:
        """STOP both axes after a failure; logs instead of raising so the first error is what surfaces."""
        for a in self.axes:
            try:
                self._write_axis_idempotent(a, "COMMAND", self.profile.commands["STOP"])
            except CommunicationError as exc:
                log.error("turntable: STOP after a failure impossible, link down: %s", exc)
                return
            except Exception as exc:  # noqa: BLE001 - already failing; keep the first error
                log.error("turntable: STOP of axis %d after a failure did not go through: %s", a, exc)

    def _wait_standstill(self, bound_s: float) -> None:
        deadline = self.clock.now() + bound_s
        while True:
            sts = [self.axis_status(a) for a in self.axes]
            if not any(st.has("MOVING") for st in sts):
                return
            if self.clock.now() >= deadline:
                raise TurntableError(f"{self.url}: still moving {bound_s} s after STOP: "
                                     + "; ".join(st.describe() for st in sts))
            self.clock.sleep(self.poll_interval)

    # ---- register access --------------------------------------------------------------------------
    def _read_globals(self, names: tuple[str, ...]) -> dict[str, int]:
        addrs = sorted((self.profile.global_regs[n], n) for n in names)
        lo, hi = addrs[0][0], addrs[-1][0]
        if hi - lo + 1 == len(addrs):
            words = self.channel.read(lo, len(addrs), "/".join(n for _, n in addrs))
            return {n: words[a - lo] for a, n in addrs}
        return {n: self.channel.read(a, 1, n)[0] for a, n in addrs}

    def _write_global(self, name: str, value: int) -> None:
        try:
            self.channel.write(self.profile.global_regs[name], [value], name)
        except ModbusExceptionError as exc:
            raise TurntableError(f"{self.url}: {name}={value} refused: {exc}") from exc

    def _read_axis_value(self, axis: int, register: str) -> int:
        n = AXIS_REGISTER_TYPES[register][0]
        words = self.channel.read(self.profile.addr(axis, register), n, f"axis {axis} {register}")
        return words_to_int(self.profile, words, register)

    def _write_axis_idempotent(self, axis: int, register: str, value: int) -> None:
        try:
            self.channel.write(self.profile.addr(axis, register), int_to_words(self.profile, value, register),
                               f"axis {axis} {register}")
        except ModbusExceptionError as exc:
            raise self._rejection(axis, f"{register}={value}", exc) from exc

    def _write_axis_block(self, axis: int, values: dict[str, int]) -> None:
        """FC16 per run of adjacent registers (one run for the default map). Idempotent: retried freely."""
        words = {}
        for reg, value in values.items():
            for k, w in enumerate(int_to_words(self.profile, value, reg)):
                words[self.profile.addr(axis, reg) + k] = w
        runs: list[tuple[int, list[int]]] = []
        for address in sorted(words):
            if runs and runs[-1][0] + len(runs[-1][1]) == address:
                runs[-1][1].append(words[address])
            else:
                runs.append((address, [words[address]]))
        for start, run in runs:
            try:
                self.channel.write(start, run, f"axis {axis} {'/'.join(values)}")
            except ModbusExceptionError as exc:
                raise self._rejection(axis, "/".join(f"{k}={v}" for k, v in values.items()), exc) from exc


class _StopOnFailure:
    """Leaves the table stopped when a motion call fails in any way (including Ctrl-C)."""

    def __init__(self, link: TurntableLink) -> None:
        self.link = link

    def __enter__(self) -> None:
        return None

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None:
            self.link._stop_quietly()
        return False


def _check_positive(**values: float) -> None:
    for name, v in values.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")


def _check_finite(**values: float) -> None:
    for name, v in values.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ValueError(f"{name} must be a finite number, got {v!r}")
