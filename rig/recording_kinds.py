"""Which command takes which kind of recording: the one place that knows (docs/reference/recording-kinds.md is
made from it, `python -m rig.recording_kinds`, and a test holds the page to it).

A session with a turntable (its reference attitude recorded) is one kind, whatever sensors it has; a recording
without one (`"reference": "none"`, session-csv.md) is of the kind its sensors make: `accel+gyro+mag`, `accel`,
`mag`, ... A command given a kind it cannot use refuses it before any work, exit 2, naming the sensor it lacks
and the commands that do take the recording (`refuse_unless_taken`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Callable

from rig.errors import InputError

SENSORS = ("accel", "gyro", "mag")
SENSOR_NAMES = {"accel": "an accelerometer", "gyro": "a gyroscope", "mag": "a magnetometer"}
TURNTABLE = "turntable session"


@dataclass(frozen=True)
class Use:
    """What a command does with one kind: whether it takes it, the sensors it uses, what it lacks or leaves
    (`note`, as the table says it) and why (`why`, as a refusal says it)."""

    taken: bool
    uses: tuple[str, ...] = ()
    note: str = ""
    why: str = ""
    lacks_sensor: bool = False        # refused for a sensor the recording does not hold (another would do)


def _present(sensors: frozenset[str]) -> tuple[str, ...]:
    return tuple(s for s in SENSORS if s in sensors)


def _lacking(sensors: frozenset[str], needed: tuple[str, ...]) -> str:
    return " and ".join(SENSOR_NAMES[s] for s in needed if s not in sensors)


def _calibrate(turntable: bool, sensors: frozenset[str]) -> Use:
    if turntable:
        return Use(True, _present(sensors))
    if not sensors & {"accel", "mag"}:
        return Use(False, note="needs an accelerometer or a magnetometer",
                   why="a gyroscope is calibrated by the gravity its motions carry between still poses",
                   lacks_sensor=True)
    if "gyro" in sensors and "accel" not in sensors:
        return Use(True, tuple(s for s in _present(sensors) if s != "gyro"),
                   "the gyroscope is not calibrated: it needs an accelerometer")
    return Use(True, _present(sensors))


def _discrepancy(turntable: bool, sensors: frozenset[str]) -> Use:
    if turntable or {"accel", "gyro"} <= sensors:
        return Use(True, _present(sensors))
    if "gyro" not in sensors:
        directions = " and ".join({"accel": "gravity's", "mag": "the field's"}[s] for s in _present(sensors))
        return Use(True, _present(sensors), f"no gyroscope: each sample replayed at the attitude {directions} "
                   f"direction{'s' if len(sensors) > 1 else ''} give{'' if len(sensors) > 1 else 's'}")
    return Use(False, note=f"needs {_lacking(sensors, ('accel', 'gyro'))}",
               why="a recording's twin replays its still poses and the motions between them", lacks_sensor=True)


def _noise(turntable: bool, sensors: frozenset[str]) -> Use:
    return Use(True, _present(sensors))


def _attitude(turntable: bool, sensors: frozenset[str]) -> Use:
    if not turntable:
        return Use(False, note="needs a reference attitude (a turntable)",
                   why="the filter's attitude is compared with the one the table recorded")
    if not {"accel", "gyro"} <= sensors:
        return Use(False, note=f"needs {_lacking(sensors, ('accel', 'gyro'))}", lacks_sensor=True)
    return Use(True, _present(sensors))


def _export(turntable: bool, sensors: frozenset[str]) -> Use:
    if not turntable:
        return Use(False, note="a recording is already an interchange folder")
    return Use(True, _present(sensors), "the rig's own folder, session.sqlite")


COMMANDS: dict[str, Callable[[bool, frozenset[str]], Use]] = {
    "calibrate": _calibrate, "discrepancy": _discrepancy, "noise": _noise, "attitude": _attitude, "export": _export}


def recording_kinds() -> list[frozenset[str]]:
    """Every sensor set a recording may hold, the fullest first."""
    return [frozenset(c) for k in (3, 2, 1) for c in combinations(SENSORS, k)]


def kind_name(turntable: bool, sensors) -> str:
    return TURNTABLE if turntable else "+".join(s for s in SENSORS if s in sensors)


def use(command: str, turntable: bool, sensors) -> Use:
    return COMMANDS[command](bool(turntable), frozenset(sensors))


def commands_taking(turntable: bool, sensors) -> list[str]:
    return [c for c in COMMANDS if use(c, turntable, sensors).taken]


def refuse_unless_taken(command: str, turntable: bool, sensors, where: str) -> Use:
    """What `command` uses of a session at `where` (a folder) of these sensors; InputError (exit 2) naming what it
    lacks and the commands that take it where it cannot use the session."""
    u = use(command, turntable, sensors)
    if u.taken:
        return u
    others = ["`rig calibrate --from`" if c == "calibrate" else f"`rig {c}`" for c in commands_taking(turntable, sensors)]
    kind = kind_name(turntable, sensors)
    why = f" ({u.why})" if u.why else ""
    raise InputError(f"{where}: `rig {command}` cannot use a recording of kind {kind} ({_has(sensors)}): it "
                     f"{u.note}{why}; " + (f"{' and '.join(others)} take{'s' if len(others) == 1 else ''} it"
                                      if others else "no command takes it")
                     + " (docs/reference/recording-kinds.md)")


def _has(sensors) -> str:
    names = [SENSOR_NAMES[s] for s in SENSORS if s in sensors]
    if len(names) == 1:
        return f"it holds {names[0]} alone"
    return "it holds " + ", ".join(names[:-1]) + " and " + names[-1]


def markdown_table() -> str:
    """The table of docs/reference/recording-kinds.md: a row per kind, a column per command."""
    rows = [(True, frozenset(SENSORS))] + [(False, k) for k in recording_kinds()]
    head = "| kind | " + " | ".join(f"`rig {c}`" for c in COMMANDS) + " |"
    lines = [head, "| --- |" + " --- |" * len(COMMANDS)]
    for turntable, sensors in rows:
        cells = []
        for c in COMMANDS:
            u = use(c, turntable, sensors)
            if not u.taken:
                cells.append(f"no: {u.note}")
            elif turntable:
                cells.append("yes" + (f" ({u.note})" if u.note else ""))
            else:
                cells.append(", ".join(u.uses) + (f" ({u.note})" if u.note else ""))
        name = TURNTABLE if turntable else kind_name(False, sensors)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(markdown_table(), end="")
