"""What the commands share: reading a session folder of either layout (the rig's own `session.sqlite` or an
interchange `meta.json` + `samples.csv`), the rig's configuration, and running a session to its exit code (the
progress bar, the stop signals, the outcome's lines, the lab mirror)."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from rig import exits
from rig.config import RigConfig, load_config
from rig.errors import InputError
from rig.exits import (CommandError, Exit, aborted, code_for, command_error, plain, stop_signal_numbers,
                       stop_signals_raise)
from rig.session_data import SessionData, with_configuration_facts


def is_rig_session(folder: Path) -> bool:
    from rig.store import SESSION_FILE

    return (Path(folder) / SESSION_FILE).is_file()


def read_any_session(folder: Path) -> SessionData:
    """The session in `folder`, whichever of the two layouts it is in; InputError naming the folder if neither."""
    folder = Path(folder)
    if is_rig_session(folder):
        from rig.store import SessionStore

        with SessionStore.open(folder) as store:
            return session_from_store(store)
    if (folder / "meta.json").is_file() or (folder / "samples.csv").is_file():
        from rig.io.session_csv import read_session

        return read_session(folder)
    raise InputError(f"{folder}: not a session folder (neither a rig session, session.sqlite, nor an interchange "
                     "session, meta.json + samples.csv)")


def session_kind(folder: Path) -> tuple[bool, list[str]] | None:
    """(has a turntable, its sensors) of an interchange session in `folder`, from meta.json alone: a command
    refuses a kind it cannot use before its samples are read (`rig.recording_kinds`). None for the rig's own
    folder (a turntable session, which every command takes) and for a folder without meta.json (the reader then
    says what it is not)."""
    folder = Path(folder)
    if is_rig_session(folder) or not (folder / "meta.json").is_file():
        return None
    from rig.io.session_meta import read_meta

    meta = read_meta(folder / "meta.json")
    return meta.get("reference", "table") != "none", list(meta["sensors"])


def session_from_store(store) -> SessionData:
    """The store's session with what the interchange layout carries beside the arrays (its configuration facts)."""
    return with_configuration_facts(store.to_session_data())


def rig_config(path, orientations) -> RigConfig:
    """The rig's configuration (the simulator's when `path` is None), its schedule size overridden if given;
    a bad file is bad input (exit 2), named with its line."""
    try:
        config = load_config(path)
    except ValueError as e:
        raise CommandError(plain(str(e)), Exit.BAD_INPUT) from None
    if orientations:
        config.schedule.orientations = orientations
    return config


class _Progress:
    """The tqdm bar of a session, made on the first report (a resumed session's length is known only then)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled, self.bar = enabled, None

    def __call__(self, k: int, n: int, phase: str) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=n, unit="orientation", desc="calibration", file=sys.stderr,
                            bar_format="{desc}: {n}/{total} {bar} [{elapsed}<{remaining}] {postfix}")
        self.bar.n = k
        self.bar.set_postfix_str(f"orientation {min(k + 1, n)}/{n} {phase}")
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def build_rig(config: RigConfig, spec):
    """The orchestrator's rig factory (`rig.assembly.build_rig`), loaded when a session runs: `calibrate --from`
    never needs the simulated hardware or the turntable link."""
    from rig import assembly

    return assembly.build_rig(config, spec)


def run_session_to(out: Path, config: RigConfig | None, *, sim: bool = False, seed: int = 0,
                   time_scale: float | None = None, method: str = "joint", progress: bool = True,
                   resume: bool = False, trial: int = 0, plots: bool | None = None, plan: dict | None = None,
                   echo=click.echo) -> int:
    """Run (or, with `resume`, finish) the session in `out` and show how it ended; returns the exit code.

    The orchestrator does the work; here are the progress bar, the stop signals and the exit code.
    """
    from procedures.orchestrator import RigSpec, SessionOrchestrator

    bar = _Progress(progress)
    orchestrator = SessionOrchestrator(out, build_rig, method=method, progress=bar, plots=plots)
    with late_stop_signals() as late:         # what the session's stop handler leaves behind: noted, not obeyed
        try:
            with stop_signals_raise():
                try:
                    if resume:
                        outcome = orchestrator.resume()
                    else:
                        outcome = orchestrator.start(config, RigSpec(sim, seed if sim else None, time_scale, trial),
                                                     plan)
                finally:
                    bar.close()
        except KeyboardInterrupt as exc:      # a stop before the session existed: nothing to mark
            import signal

            signum = getattr(exc, "signum", signal.SIGINT)
            echo(f"aborted by {_signal_name(signum)} before recording began; nothing new was recorded", err=True)
            return aborted(signum)
        except Exception as exc:
            if not _is_known(exc):
                raise
            raise command_error(exc, prefix="" if resume else "cannot start the session: ") from None
        code = show_slots_outcome(outcome, echo) if hasattr(outcome, "slots") else show_outcome(outcome, echo)
    if late:
        echo(f"{_signal_name(late[0])} came after the session had ended ({outcome.status}): nothing left to stop",
             err=True)
    return code


@contextlib.contextmanager
def late_stop_signals():
    """A stop signal once the session has ended and its status is stored is noted, not obeyed: the exit code
    stays the one of the session's stored end (a SIGTERM racing a failed session's exit killed the process with
    the signal's code while the store said `failed`; found by the fault campaign). In the `rig` process itself
    the note stays until the process exits, since a signal between this block and the exit would kill it with
    the signal's code all the same; inside another program the handlers are given back."""
    import signal

    late: list[int] = []
    before = {sig: signal.signal(sig, lambda signum, frame: late.append(signum)) for sig in stop_signal_numbers()}
    try:
        yield late
    finally:
        if not exits.process_ends_with_command:
            for sig, old in before.items():
                signal.signal(sig, old)


def _signal_name(signum: int) -> str:
    from rig.errors import signal_name

    return signal_name(signum)


def _is_known(exc: BaseException) -> bool:
    from rig.errors import RigError

    return isinstance(exc, (RigError, OSError)) or type(exc).__module__.startswith("drivers")


def show_outcome(outcome, echo=click.echo) -> int:
    """Print the end of a session (summary, warnings, truth, verdict or the reason it stopped); its exit code."""
    out = outcome.folder
    if outcome.status == "aborted":
        echo(f"\naborted: {outcome.reason}; {outcome.holds}/{outcome.n_holds} holds recorded in {out}; "
             f"finish with: rig resume {out}", err=True)
        return aborted(outcome.signum)
    if outcome.status == "failed":
        echo(f"session failed: {plain(outcome.reason)} ({outcome.holds}/{outcome.n_holds} holds are kept in {out}; "
             f"`rig resume {out}` continues)", err=True)
        if outcome.error_log is not None:            # not a known fault: a bug, its traceback in the log
            return Exit.INTERNAL
        return code_for(outcome.error) if outcome.error is not None else Exit.FAILED
    for line in outcome.summary:
        echo(line)
    for line in outcome.warnings:
        echo(f"warning: {line}", err=True)
    for line in outcome.truth_lines:
        echo(line)
    echo("wrote " + " and ".join(str(p) for p in outcome.written))
    if outcome.verdict == "FAIL":
        echo(f"verdict: FAIL ({plain(outcome.reason.removeprefix('verdict FAIL: '))}); the session is stored as "
             "rejected", err=True)
        return Exit.FAIL
    echo(f"verdict: {outcome.verdict}" + (" (no limits configured)" if outcome.verdict == "NOT CHECKED" else ""))
    return Exit.OK


def show_slots_outcome(outcome, echo=click.echo) -> int:
    """One line per slot (its end, its H error against the truth when simulated, its folder) and the shared table
    time; exit 0 when every slot passed, 1 when any failed its limits or was dropped, a stop's or fault's code when
    the session as a whole ended so."""
    codes = []
    for name, one in outcome.slots.items():
        errors = ", ".join(f"{sensor} {pct:.3f} %" for sensor, pct in one.h_error_pct.items())
        end = one.verdict if one.status in ("complete", "rejected") else one.status
        echo(f"slot {name}: {end}" + (f"; H error vs truth: {errors}" if errors else "") + f"; {one.folder}")
        if one.status in ("failed", "aborted") or one.verdict == "FAIL":
            echo(f"  slot {name}: {plain(one.reason)} ({one.holds}/{one.n_holds} holds kept)", err=True)
        for line in one.warnings:
            echo(f"  warning: slot {name}: {line}", err=True)
        if one.status == "aborted":
            codes.append(aborted(one.signum))
        elif one.status == "failed" and one.error is not None:
            codes.append(Exit.INTERNAL if one.error_log is not None else code_for(one.error))
        elif one.status == "failed" or one.verdict == "FAIL":
            codes.append(Exit.FAIL)
    if outcome.table_time_s is not None:
        echo(f"table time: {outcome.table_time_s:.1f} s for {len(outcome.slots)} slots (shared)")
    if any(o.status in ("failed", "aborted") and o.error is not None or o.status == "aborted"
           for o in outcome.slots.values()):
        echo(f"`rig resume {outcome.folder}` continues every slot still recorded", err=True)
    faults = [c for c in codes if c != Exit.FAIL]
    return faults[0] if faults else (Exit.FAIL if codes else Exit.OK)


@contextlib.contextmanager
def mirrored(out: Path, store: str | None, slot_folders: list[Path] | None = None):
    """The session recorded in `out` and, with a database store, mirrored into it while it runs (rig.lab.mirror:
    the rig never waits for the network); a folder store is where session folders lie, so `out` must be in it.
    A session of several slots is mirrored as one session per slot (`slot_folders`, each its own unit)."""
    if store is None:
        yield
        return
    from rig.lab.errors import is_database_url

    if not is_database_url(store):
        if not Path(out).resolve().is_relative_to(Path(store).resolve()):
            raise CommandError(f"--store {store}: a folder store holds session folders, and {out} is not inside it "
                               f"(e.g. {Path(store) / Path(out).name})", Exit.BAD_INPUT)
        yield
        return
    try:
        from rig.lab.mirror import live_mirror
    except ModuleNotFoundError as exc:
        raise CommandError(f"--store {store}: the lab's store needs the package {exc.name!r}: "
                           "pip install 'rig[lab]'", Exit.BAD_INPUT) from None
    with contextlib.ExitStack() as mirrors:
        for folder in slot_folders or [out]:
            mirrors.enter_context(live_mirror(folder, store))
        yield
