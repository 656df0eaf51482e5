"""The exit codes of every `rig` command (`EXIT_TABLE`, from which docs/reference/exit-codes.md is generated), how
errors map onto them, and the option types that refuse bad numbers at the command line.
`tests/faults/test_exit_table.py` makes every code of the table with a real command."""

from __future__ import annotations

import contextlib
import enum
import math
import os
import re
import signal

import click

from rig.errors import Busy, InputError, StopSignal


# True in the `rig` process itself (set by the command line's entry), where the process exits as soon as its
# command returns; False where a command runs inside another program (a test runner).
process_ends_with_command = False


class Exit(enum.IntEnum):
    OK = 0
    FAIL = 1
    BAD_INPUT = 2
    FAILED = 3
    BUSY = 4
    INTERNAL = 70


# (codes, meaning, the session's stored status): the one table every command's exit follows
EXIT_TABLE = (
    ((0,), "done; a session calibrated with verdict PASS (or no limits configured)", "complete"),
    ((1,), "done, but a check did not pass: the calibration's verdict is FAIL (the failing limits printed and in "
           "report.md); `rig plan`: an axis is not excited; `rig discrepancy`: a sensor could not be analysed",
     "rejected"),
    ((2,), "bad input: an option, a configuration, a value the table refuses (beyond its limits), a folder that is "
           "not a session or already holds what would be replaced (without --force), a file that breaks its "
           "format, credentials or a role the store refuses; nothing was changed", "unchanged"),
    ((3,), "failed: a fault of the hardware, the turntable or chamber link, the data, the disk or the store's "
           "server; what was recorded is kept and `rig resume` (or `rig push`) continues", "failed"),
    ((4,), "busy: the session folder, the turntable, the chamber or a TCP port is in use by another process, named",
     "unchanged"),
    ((70,), "internal error (a bug): one line naming the file its traceback was written to", "failed"),
    ((129, 130, 143), "aborted by SIGHUP, SIGINT (Ctrl-C), SIGTERM (128 + the signal); the table stopped and "
                      "disabled", "aborted"),
)


STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


def _raise_once():
    """A handler that raises `StopSignal(signum)` for the first stop signal and ignores the ones after it."""
    stopping = []

    def handler(signum, frame):
        if stopping:
            return
        stopping.append(signum)
        raise StopSignal(signum)

    return handler


def stop_signal_numbers() -> list[int]:
    """The numbers of STOP_SIGNALS this platform has."""
    return [getattr(signal, name) for name in STOP_SIGNALS if hasattr(signal, name)]


@contextlib.contextmanager
def stop_signals_raise():
    """SIGINT, SIGTERM and SIGHUP raise `StopSignal(signum)` where the work is (like Ctrl-C, but naming the
    signal), once: a repeat while the table is being made safe, or a pool of workers closed, is ignored, so the
    stop cannot be cut short. Work that starts processes runs inside it, so they are ended on the way out rather
    than left behind by the default death."""
    handler = _raise_once()
    before = {sig: signal.signal(sig, handler) for sig in stop_signal_numbers()}
    try:
        yield
    finally:
        for sig, old in before.items():
            signal.signal(sig, old)


def stop_signals_raise_until_exit() -> None:
    """The `rig` process's own handlers, set as it starts: every command ends on SIGTERM or SIGHUP as on Ctrl-C
    (one line, 128 + N, its `finally` blocks run: a half-written file's temporary removed, a store closed) rather
    than by the signal's default death, which said nothing and left them. Commands that stop a table or a pool
    put their own handlers over these (`stop_signals_raise`) and give them back after; never given back here,
    since the process ends with its command."""
    handler = _raise_once()
    for sig in stop_signal_numbers():
        signal.signal(sig, handler)


def aborted(signum: int | None) -> int:
    """The exit code of a run stopped by `signum` (SIGINT when unknown)."""
    return 128 + int(signum if signum is not None else signal.SIGINT)


class CommandError(click.ClickException):
    """A message and the exit code it deserves (click's own errors exit 1, which here means a FAIL verdict)."""

    def __init__(self, message: str, code: int = Exit.FAILED) -> None:
        super().__init__(message)
        self.exit_code = int(code)


def code_for(exc: BaseException) -> int:
    """The exit code of an error raised by the rig's code."""
    if isinstance(exc, Busy):
        return Exit.BUSY
    if isinstance(exc, InputError):
        return Exit.BAD_INPUT
    return Exit.FAILED


def command_error(exc: BaseException, prefix: str = "") -> CommandError:
    """`exc` as a CommandError with its message (plain numbers, not numpy reprs) and its exit code."""
    if isinstance(exc, OSError) and exc.strerror:
        return CommandError(prefix + (f"{exc.filename}: " if exc.filename else "") + exc.strerror, code_for(exc))
    message = plain(str(exc))
    names_it = message.startswith(prefix) or message.startswith(prefix.removesuffix(": ") + os.sep)
    if prefix and names_it:                            # the error names the folder (session.source) or a file in it
        prefix = ""
    return CommandError(prefix + message, code_for(exc))


def plain(text: str) -> str:
    """Messages built with repr() of numpy scalars read 'np.float64(1.5)'; a user wants '1.5'."""
    text = re.sub(r"np\.(?:float|int|uint|complex|str_|bool_?)\d*\(([^()]*)\)", r"\1", text)
    return re.sub(r"np\.(True|False)_", r"\1", text)


class FiniteFloat(click.ParamType):
    """A finite number, optionally within [low, high] (open at an end with low_open / high_open): click's
    FloatRange lets NaN through, and `--time-scale nan` must be refused here, not deep inside a session."""

    name = "number"

    def __init__(self, low: float | None = None, high: float | None = None, *, low_open: bool = False,
                 high_open: bool = False) -> None:
        self.low, self.high, self.low_open, self.high_open = low, high, low_open, high_open

    def convert(self, value, param, ctx):
        try:
            number = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        if self.low is not None and (number < self.low or (self.low_open and number == self.low)):
            self.fail(f"{value} must be {'>' if self.low_open else '>='} {self.low:g}", param, ctx)
        if self.high is not None and (number > self.high or (self.high_open and number == self.high)):
            self.fail(f"{value} must be {'<' if self.high_open else '<='} {self.high:g}", param, ctx)
        return number


def busy_port(host: str, port: int) -> str:
    """Who holds a TCP port that cannot be bound ("in use by pid N (COMMAND)"), for a busy (4) message: the
    listening socket's inode from /proc/net/tcp{,6}, then the process that has it open. Said plainly when it
    cannot be found (another user's process, not Linux)."""
    inodes = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table) as f:
                next(f, None)
                for line in f:
                    fields = line.split()
                    if len(fields) > 9 and fields[3] == "0A" and int(fields[1].rsplit(":", 1)[1], 16) == port:
                        inodes.add(fields[9])
        except (OSError, ValueError, IndexError):
            continue
    wanted = {f"socket:[{inode}]" for inode in inodes}
    if wanted:
        for pid in sorted(p for p in os.listdir("/proc") if p.isdigit()):
            try:
                fds = os.listdir(f"/proc/{pid}/fd")
                if any(os.readlink(f"/proc/{pid}/fd/{fd}") in wanted for fd in fds):
                    with open(f"/proc/{pid}/cmdline", "rb") as f:
                        command = f.read().replace(b"\0", b" ").decode(errors="replace").strip()
                    return f"port {port} is in use by pid {pid} ({command[:120]})"
            except OSError:
                continue
    return f"port {port} is in use by another process"
