"""Errors of the rig package (drivers have their own hierarchy rooted at `drivers.DriverError`)."""

from __future__ import annotations


class RigError(Exception):
    """Base of the rig's own errors."""


class SessionFormatError(RigError, ValueError):
    """A measured-session file breaks the interchange layout; names file, line and column."""

    def __init__(self, file: str, message: str, line: int | None = None, column: str | None = None) -> None:
        self.file, self.line, self.column = str(file), line, column
        where = self.file + (f", line {line}" if line is not None else "") + (f", column '{column}'" if column else "")
        super().__init__(f"{where}: {message}")


class CalibrationError(RigError, ValueError):
    """The data cannot give a trustworthy calibration (too few or coplanar orientations, NaN, ...)."""
