"""Errors of the rig package (drivers have their own hierarchy rooted at `drivers.DriverError`).

The command layer turns them into exit codes (docs/reference/exit-codes.md): an `InputError` is the user's to fix
(a file, a folder, an option), a `Busy` is another process holding what this one needs, any other `RigError`
is a fault of the rig or its data.
"""

from __future__ import annotations

import signal


class RigError(Exception):
    """Base of the rig's own errors."""


class InputError(RigError, ValueError):
    """Something the user gave (an option, a folder, a configuration or data file) cannot be used as it is."""


class Busy(RigError):
    """Another process holds the session folder or the turntable link; names the holder."""


class SessionFormatError(InputError):
    """A measured-session file breaks the interchange layout; names file, line and column."""

    def __init__(self, file: str, message: str, line: int | None = None, column: str | None = None) -> None:
        self.file, self.line, self.column = str(file), line, column
        where = self.file + (f", line {line}" if line is not None else "") + (f", column '{column}'" if column else "")
        super().__init__(f"{where}: {message}")


class CalibrationError(RigError, ValueError):
    """The data cannot give a trustworthy calibration (too few or coplanar orientations, NaN, ...)."""


class StopSignal(KeyboardInterrupt):
    """A stop signal (SIGINT, SIGTERM, SIGHUP) arrived; raised where the work is, like Ctrl-C, but naming
    the signal that really came so the session records it truthfully."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(signal_name(self.signum))


def signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"
