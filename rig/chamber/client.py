"""`ChamberLink`: drive a thermal chamber's temperature controller over Modbus by its register profile.

All waiting (polls, timeouts, retry backoff) goes through the injected clock, so with a simulated clock and
the fake chamber an hour's soak runs in a fraction of a second.

"Safe" for a chamber (what `stop()` and leaving the `with` block do): the set point goes back to the
profile's ambient (23 C by default) and the chamber's RUN event is switched off, so neither the heater nor
the compressor works unattended and a controller that ignores the event drives the air nowhere extreme.
The air is not waited for: it drifts back to the room on its own.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from rig.chamber.errors import (LINK_ERRORS, ChamberAlarm, ChamberError, CommunicationError, IdentityError,
                                ModbusExceptionError, SetPointNotReached)
from rig.chamber.profile import ChamberProfile, load_profile
from rig.chamber.words import c_to_f, f_to_c, float_to_words, words_to_float
from rig.clock import Clock, RealClock
from rig.modbus.channel import ModbusChannel
from rig.modbus.device import ModbusDevice
from rig.modbus.url import parse_url

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ChamberStatus:
    """One reading of the controller: temperatures in C, names as the profile spells them."""

    air_c: float
    set_point_c: float
    working_set_point_c: float | None
    ramp_c_per_min: float | None          # None: the set point steps (ramp off)
    running: bool
    device_status: str
    alarm: str                            # "" when no alarm

    def describe(self) -> str:
        ramp = "off" if self.ramp_c_per_min is None else f"{self.ramp_c_per_min:g} C/min"
        working = "" if self.working_set_point_c is None else f" (working {self.working_set_point_c:.2f} C)"
        return (f"air {self.air_c:.2f} C, set point {self.set_point_c:.2f} C{working}, ramp {ramp}, "
                f"{'running' if self.running else 'stopped'}, device {self.device_status}"
                + (f", ALARM {self.alarm}" if self.alarm else ""))


class ChamberLink(ModbusDevice):
    """A context manager around one chamber controller; leaving the `with` block leaves the chamber safe."""

    def __init__(self, url: str, profile: ChamberProfile | str | Path | None = None, clock: Clock | None = None,
                 timeout: float = 1.0, retries: int = 3, poll_interval: float = 2.0,
                 device_id: int | None = None) -> None:
        self.profile = profile if isinstance(profile, ChamberProfile) else load_profile(profile)
        self.url = url
        self.clock: Clock = clock if clock is not None else RealClock()
        if not (math.isfinite(poll_interval) and poll_interval > 0):
            raise ValueError(f"poll_interval must be positive, got {poll_interval}")
        self.poll_interval = poll_interval
        self.device_id = self.profile.device_id if device_id is None else device_id
        self.channel = ModbusChannel(parse_url(url, "chamber"), self.device_id, self.clock, timeout, retries,
                                     device="chamber", errors=LINK_ERRORS)
        self.fahrenheit = self.profile.modbus_units == "F"

    def identify(self) -> str:
        """DEVICE_STATUS by name (must be OK); also reads DISPLAY_UNITS when the profile follows it."""
        p = self.profile
        state = "unchecked"
        if p.has("DEVICE_STATUS"):
            try:
                word = self._read_word("DEVICE_STATUS")
            except ModbusExceptionError as exc:
                raise IdentityError(f"{self.url}: does not answer as a {p.name} controller (profile {p.path}): "
                                    f"{exc}") from exc
            state = p.value_name("DEVICE_STATUS", word)
            if word != p.values["DEVICE_STATUS"]["OK"]:
                raise IdentityError(f"{self.url}: DEVICE_STATUS reads {state} ({word}), not OK "
                                    f"({p.values['DEVICE_STATUS']['OK']}) as profile {p.path} expects")
        if p.modbus_units == "display":
            units = self._read_word("DISPLAY_UNITS")
            names = p.values["DISPLAY_UNITS"]
            if units not in (names["C"], names["F"]):
                raise IdentityError(f"{self.url}: DISPLAY_UNITS reads {units}, neither C ({names['C']}) nor F "
                                    f"({names['F']}) of profile {p.path}")
            self.fahrenheit = units == names["F"]
        return state

    # ---- reading ----------------------------------------------------------------------------------
    def air_c(self) -> float:
        """The process value: the chamber's air temperature, C."""
        return self._to_c(self._read_float("PROCESS_VALUE"))

    def status(self) -> ChamberStatus:
        p = self.profile
        action = self._read_word("RAMP_ACTION")
        ramp = None
        if action in (p.values["RAMP_ACTION"]["SET_POINT"], p.values["RAMP_ACTION"].get("BOTH", -1)):
            rate = self._read_float("RAMP_RATE")
            per_hour = self._read_word("RAMP_SCALE") == p.values["RAMP_SCALE"].get("PER_HOUR", -1)
            ramp = self._delta_to_c(rate) / (60.0 if per_hour else 1.0)
        alarm = ""
        if p.has("ALARM_STATE"):
            word = self._read_word("ALARM_STATE")
            if word not in p.values.get("ALARM_STATE", {}).values():
                alarm = f"alarm 1 state {word}"
        device = p.value_name("DEVICE_STATUS", self._read_word("DEVICE_STATUS")) if p.has("DEVICE_STATUS") else "?"
        working = self._to_c(self._read_float("WORKING_SET_POINT")) if p.has("WORKING_SET_POINT") else None
        return ChamberStatus(air_c=self.air_c(), set_point_c=self._to_c(self._read_float("SET_POINT")),
                             working_set_point_c=working, ramp_c_per_min=ramp,
                             running=self._read_word("RUN") == p.values["RUN"]["ON"],
                             device_status=device, alarm=alarm)

    # ---- commands ---------------------------------------------------------------------------------
    def set_point(self, c: float) -> None:
        """Write the set point, C; refused (ValueError) outside the profile's limits."""
        p = self.profile
        if not (isinstance(c, (int, float)) and math.isfinite(c) and p.min_c <= c <= p.max_c):
            raise ValueError(f"set point {c!r} C is outside the chamber's limits {p.min_c:g}..{p.max_c:g} C "
                             f"(profile {p.path})")
        self._write_float("SET_POINT", self._from_c(float(c)))

    def ramp_rate(self, c_per_min: float | None) -> None:
        """Ramp the set point at `c_per_min` (C per minute); 0 or None: set points step (ramp off)."""
        p = self.profile
        if c_per_min is None or c_per_min == 0:
            self._write_word("RAMP_ACTION", p.values["RAMP_ACTION"]["OFF"])
            return
        if not (isinstance(c_per_min, (int, float)) and math.isfinite(c_per_min)
                and 0 < c_per_min <= p.max_ramp_c_per_min):
            raise ValueError(f"ramp rate {c_per_min!r} C/min must be in (0, {p.max_ramp_c_per_min:g}] "
                             f"(profile {p.path})")
        self._write_word("RAMP_SCALE", p.values["RAMP_SCALE"]["PER_MINUTE"])
        self._write_float("RAMP_RATE", self._delta_from_c(float(c_per_min)))
        self._write_word("RAMP_ACTION", p.values["RAMP_ACTION"]["SET_POINT"])

    def run(self) -> None:
        """Switch the chamber's conditioning on (the RUN event)."""
        self._write_word("RUN", self.profile.values["RUN"]["ON"])

    def stop(self) -> None:
        """Leave the chamber safe: set point back to ambient, then conditioning off (module docstring); the
        conditioning is switched off even when the set point is refused."""
        try:
            self._write_float("SET_POINT", self._from_c(self.profile.ambient_c))
        finally:
            self._write_word("RUN", self.profile.values["RUN"]["OFF"])

    def make_safe(self) -> None:
        """`stop()` that never raises (it runs in `finally` paths); a link that is down is logged."""
        if not self.channel.is_open:
            return
        try:
            self.stop()
        except CommunicationError as exc:
            log.error("chamber make_safe: link down, chamber left as it was: %s", exc)
        except Exception as exc:  # noqa: BLE001 - a finally path must not raise
            log.error("chamber make_safe: stop failed: %s", exc)

    def wait_air(self, target_c: float, tolerance_c: float, timeout: float, settle_s: float = 0.0,
                 on_poll: Callable[[float, float], None] | None = None) -> float:
        """Poll the air until it is within `tolerance_c` of `target_c` for `settle_s`; returns the last air, C.

        Raises `SetPointNotReached` after `timeout` s, `ChamberAlarm` if the controller raises an alarm on the
        way; `on_poll(t, air_c)` sees every reading. The chamber is left as it is either way (the caller
        decides whether a missed set point ends the session).
        """
        for name, v in (("tolerance_c", tolerance_c), ("timeout", timeout)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not (math.isfinite(settle_s) and settle_s >= 0):
            raise ValueError(f"settle_s must be >= 0, got {settle_s!r}")
        deadline = self.clock.now() + timeout
        since: float | None = None
        while True:
            now = self.clock.now()
            air = self.air_c()
            if on_poll is not None:
                on_poll(now, air)
            self._raise_on_alarm()
            if abs(air - target_c) <= tolerance_c:
                since = now if since is None else since
                if now - since >= settle_s:
                    return air
            else:
                since = None
            if now >= deadline:
                raise SetPointNotReached(target_c, tolerance_c, air, timeout, self.url)
            self.clock.sleep(min(self.poll_interval, max(deadline - now, 1e-3)))

    # ---- internals --------------------------------------------------------------------------------
    def _raise_on_alarm(self) -> None:
        p = self.profile
        if p.has("ALARM_STATE"):
            word = self._read_word("ALARM_STATE")
            if word not in p.values.get("ALARM_STATE", {}).values():
                raise ChamberAlarm(f"{self.url}: the controller reports alarm 1 state {word} "
                                   f"(not one of {sorted(p.values.get('ALARM_STATE', {}))})")

    def _to_c(self, value: float) -> float:
        return f_to_c(value) if self.fahrenheit else value

    def _from_c(self, c: float) -> float:
        return c_to_f(c) if self.fahrenheit else c

    def _delta_to_c(self, value: float) -> float:
        return value / 1.8 if self.fahrenheit else value

    def _delta_from_c(self, c: float) -> float:
        return c * 1.8 if self.fahrenheit else c

    def _read_float(self, name: str) -> float:
        words = self.channel.read(self.profile.floats[name], 2, name)
        return words_to_float(words, self.profile.word_order)

    def _read_word(self, name: str) -> int:
        return self.channel.read(self.profile.words[name], 1, name)[0]

    def _write_float(self, name: str, value: float) -> None:
        self._write(name, self.profile.floats[name], float_to_words(value, self.profile.word_order), value)

    def _write_word(self, name: str, value: int) -> None:
        self._write(name, self.profile.words[name], [value], self.profile.value_name(name, value))

    def _write(self, name: str, address: int, words: list[int], shown) -> None:
        """Every chamber write sets a value (never a one-shot command), so a lost reply is re-sent freely."""
        try:
            self.channel.write(address, words, name)
        except ModbusExceptionError as exc:
            raise ChamberError(f"{self.url}: {name}={shown} refused: {exc}") from exc
