"""The one owner of a calibration session: create or resume it, plan and check the schedule, record, finish.

`SessionOrchestrator.start` plans and checks the schedule before anything exists, takes the session folder's
lock and the turntable's, builds the rig through the factory it was given (real or simulated is the caller's
choice), creates the store and records; `resume` takes the same locks, reads the schedule and the rig from the
store and records the rest; both then calibrate, write calibration.json (`rig.pipeline.writing`, the one
writer) and the report, and record a status that says how it ended:

- complete / rejected: calibrated, verdict PASS (or no limits) / FAIL;
- aborted: a stop signal (the signal named), the table stopped and disabled;
- failed: a fault (hardware, communication, the data, the disk), named; recorded holds are kept.

A resumed run starts by holding again at the last orientation recorded (procedures.move_and_hold.run_session),
and the clock gap before it is recorded (`SessionStore.mark_resume`), so no move is integrated across an
interruption and none is stored twice. Nothing here prints or exits: the command shows the `Outcome`.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import signal
import traceback
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, ContextManager

import numpy as np

from rig.schedule import Orientation
from drivers.errors import DriverError
from procedures.acquisition import grid_rate_hz
from procedures.session import check_plan, plan_for, record, session_metadata, write_json
from procedures.slot_session import (MANIFEST, RecordingRig, SlotsOutcome, is_slots_session, new_manifest,
                                     read_manifest, shared_table)
from procedures.slots import DROPPED_EVENT, SlotsBoard, SlotStores
from rig.config import RigConfig, config_from_dict
from rig.errors import Busy, CalibrationError, InputError, RigError, signal_name
from rig.locks import session_lock, table_lock
from rig.pipeline import calibrate_session
from rig.pipeline.writing import write_session_calibration
from rig.report.calibration_report import evaluate, write_report
from rig.store import SESSION_FILE, NotASession, SessionStore
from rig.store.status import FINISHED_STATUSES

Progress = Callable[[int, int, str], None]
RESUME_GAP_S = 1.0          # session time left between the last sample of a run and the first of its resumption
ERROR_LOG = "rig-error.log"


@dataclass(frozen=True)
class RigSpec:
    """What the rig is built from besides the configuration; kept in the metadata so `resume` rebuilds it."""

    simulated: bool = False
    seed: int | None = None
    time_scale: float | None = None
    trial: int = 0
    run: int = 0            # 0: the run that starts the session, k: its k-th resume (simulated faults are per run)

    @classmethod
    def from_metadata(cls, meta: dict) -> "RigSpec":
        return cls(bool(meta.get("simulated")), meta.get("seed"), meta.get("time_scale"), int(meta.get("trial") or 0))


# (configuration, spec) -> the built rig as a context manager (it owns its buses and table link)
RigFactory = Callable[[RigConfig, RigSpec], ContextManager[Any]]


class PlanError(InputError):
    """The schedule cannot excite every axis; nothing was created and nothing moved."""


@dataclass
class Outcome:
    """How a session run ended, for the command to show and turn into an exit code."""

    folder: Path
    status: str                          # complete | rejected | aborted | failed
    reason: str = ""
    verdict: str | None = None           # PASS | FAIL | NOT CHECKED, once calibrated
    holds: int = 0                       # holds recorded in the session
    n_holds: int = 0                     # holds in the schedule
    signum: int | None = None            # the stop signal of an aborted run
    error: BaseException | None = None   # the fault of a failed run
    error_log: Path | None = None        # where its traceback was written, when it was not a known fault
    summary: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    truth_lines: list[str] = field(default_factory=list)
    written: list[Path] = field(default_factory=list)
    h_error_pct: dict[str, float] = field(default_factory=dict)   # simulated: each sensor's H error vs the truth


class SessionOrchestrator:
    """Runs one session folder. `build_rig` makes the rig; `progress(k, n, phase)` is told where it is."""

    def __init__(self, folder: Path, build_rig: RigFactory, *, method: str = "joint",
                 progress: Progress | None = None, plots: bool | None = None) -> None:
        self.folder = Path(folder)
        self.plots = plots          # draw the report's figures (after the result is written); None: unless simulated
        self.build_rig = build_rig
        self.method = method
        self.progress = progress

    # -- a new session ---------------------------------------------------------------------------
    def start(self, config: RigConfig, spec: RigSpec, plan: dict | None = None) -> Outcome:
        """Plan, check, create and record a new session in the folder, then finish it. `plan`: what the planner
        chose and predicted (`rig.planner.Plan.to_dict`), kept in the metadata beside what is achieved.
        A configuration of several slots records them all in one session (`SlotsOutcome`)."""
        if config.slots:
            return self._start_slots(config, spec, plan)
        schedule = self._new_folder(config)
        with contextlib.ExitStack() as held:
            held.enter_context(session_lock(self.folder))
            self._refuse_existing()
            with table_lock(config.turntable.url), self.build_rig(config, spec) as rig:
                rig.board.start()
                truth = rig.truth_fn() if getattr(rig, "truth_fn", None) else None
                meta = session_metadata(config, schedule, sim=spec.simulated,
                                        seed=spec.seed if spec.simulated else None, time_scale=spec.time_scale)
                meta.update(trial=spec.trial, chips=rig.board.settings(), table_url=getattr(rig.table, "url", None),
                            sample_rate_hz=grid_rate_hz(rig.board, config.schedule.rate_hz))
                if truth is not None:
                    meta["truth"] = truth
                if plan is not None:
                    meta["plan"] = plan
                store = held.enter_context(SessionStore.create(self.folder, meta))
                try:
                    if truth is not None:
                        write_json(self.folder / "truth.json", truth)
                except OSError as exc:
                    return self._failed(store, exc, len(schedule))
                outcome = self._record(rig, store, schedule, 0, resumed=False)
            return outcome or self._finish(store, len(schedule))

    def _new_folder(self, config: RigConfig) -> list[Orientation]:
        """The configuration's schedule, checked, and the folder made for it; refused (PlanError, NotASession)
        before anything is created when the schedule cannot excite every axis or a session is already here."""
        schedule = plan_for(config)
        problems = check_plan(config, schedule)
        if problems:
            raise PlanError("the schedule cannot excite every axis: " + "; ".join(problems))
        self._refuse_existing()
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise NotASession(f"{self.folder}: cannot create the session folder: {exc.strerror}") from None
        return schedule

    def _refuse_existing(self) -> None:
        """A folder that holds a session already: busy (4, the holder named) while another process runs it,
        else refused (2) pointing at `rig resume`, which then works."""
        if (self.folder / SESSION_FILE).exists() or (self.folder / MANIFEST).exists():
            with session_lock(self.folder):
                pass
            raise NotASession(f"{self.folder}: a session already exists here; finish it with `rig resume "
                              f"{self.folder}` or choose another --out")

    # -- resuming --------------------------------------------------------------------------------
    def resume(self) -> Outcome:
        """Record what an interrupted session lacks (from its last hold, held again), then finish it."""
        if is_slots_session(self.folder):
            return self._resume_slots()
        if not (self.folder / SESSION_FILE).is_file():
            SessionStore.open(self.folder).close()          # raises NotASession naming what is wrong
        with contextlib.ExitStack() as held:
            held.enter_context(session_lock(self.folder))    # another process on it: refused, nothing touched
            store = held.enter_context(SessionStore.open(self.folder))
            meta = store.metadata
            if meta.get("slot"):       # its table carried other slots: they are resumed together
                raise InputError(f"{self.folder}: slot {meta['slot'].get('name')} of the session in "
                                 f"{self.folder.parent}; resume every slot with `rig resume {self.folder.parent}`")
            if meta.get("status") in FINISHED_STATUSES:
                raise InputError(f"{self.folder}: the session is already finished (status {meta['status']}, "
                                 f"verdict {meta.get('verdict', 'n/a')}); nothing to resume")
            try:
                config = config_from_dict(meta["config"])
                schedule = [Orientation(**o) for o in meta["schedule"]]
            except (KeyError, TypeError, ValueError) as exc:
                raise InputError(f"{store.path}: the session's metadata cannot be read back ({exc})") from None
            done = store.completed_holds()
            if done and max(done) + 1 >= len(schedule):
                return self._finish(store, len(schedule))
            store.keep_reserve()
            with contextlib.ExitStack() as hardware:
                try:
                    hardware.enter_context(table_lock(config.turntable.url))
                    spec = replace(RigSpec.from_metadata(meta), run=len(store.resume_times()) + 1)
                    rig = hardware.enter_context(self.build_rig(config, spec))
                    rig.board.start()
                except Busy:
                    raise
                except RigError as exc:
                    self._mark(store, "failed", f"resume failed before recording: {exc}")
                    raise
                except Exception as exc:
                    return self._failed(store, exc, len(schedule), prefix="resume failed before recording: ")
                outcome = self._record(rig, store, schedule, max(done) if done else 0, resumed=True)
            return outcome or self._finish(store, len(schedule))

    # -- recording -------------------------------------------------------------------------------
    def _record(self, rig, store: SessionStore, schedule: list[Orientation], start: int, *,
                resumed: bool) -> Outcome | None:
        """Record holds `start..`; None when all are recorded, else the Outcome of the stop or fault."""
        n = len(schedule)
        try:
            store.set_status("running", "resumed" if resumed else "")
            t0 = 0.0
            if resumed:
                last = store.last_time()
                t0 = 0.0 if last is None else last + RESUME_GAP_S
                store.mark_resume(t0, last, f"rig resume, from hold {start} (held again)")
            stats = record(rig, store, schedule, start_step=start, session_t0=t0, progress=self.progress)
            store.update_metadata(acquisition=_added(store.metadata.get("acquisition"), stats))
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", signal.SIGINT)
            reason = f"stopped by {signal_name(signum)}; the table was stopped and disabled"
            reason = self._mark(store, "aborted", reason)
            return Outcome(self.folder, "aborted", reason, holds=len(store.completed_holds()), n_holds=n,
                           signum=signum)
        except Exception as exc:
            return self._failed(store, exc, n, url=getattr(rig.table, "url", None))
        return None

    # -- several slots ---------------------------------------------------------------------------
    def _start_slots(self, config: RigConfig, spec: RigSpec, plan: dict | None) -> SlotsOutcome:
        """One session folder per slot under the folder, the manifest beside them, every slot recorded on the
        one schedule and tick grid, each calibrated on its own."""
        schedule = self._new_folder(config)
        with contextlib.ExitStack() as held:
            held.enter_context(session_lock(self.folder))
            self._refuse_existing()
            with table_lock(config.turntable.url), self.build_rig(config, spec) as rig:
                board = self._started(rig.boards)
                stores = {}
                for slot in config.slots:
                    folder = self.folder / slot.name
                    folder.mkdir(exist_ok=True)
                    held.enter_context(session_lock(folder))
                    meta = self._slot_metadata(rig, slot, schedule, spec, plan)
                    meta["sample_rate_hz"] = grid_rate_hz(board, config.schedule.rate_hz)
                    stores[slot.name] = held.enter_context(SessionStore.create(folder, meta))
                    if "truth" in meta:
                        write_json(folder / "truth.json", meta["truth"])
                write_json(self.folder / MANIFEST, new_manifest(config, spec, rig.configs))
                outcomes = self._record_slots(rig, board, stores, schedule, 0, resumed=False)
            return self._finish_slots(stores, len(schedule), outcomes)

    def _started(self, boards: dict) -> SlotsBoard:
        """The slots' boards as one, each started; a slot whose chips do not answer is dropped, not the session."""
        board = SlotsBoard(boards)
        for name, one in boards.items():
            try:
                one.start()
            except DriverError as exc:
                board.drop(name, f"slot {name}: its chips did not start: {exc}")
        return board

    def _slot_metadata(self, rig, slot, schedule: list[Orientation], spec: RigSpec, plan: dict | None) -> dict:
        config = rig.configs[slot.name]
        meta = session_metadata(config, schedule, sim=spec.simulated, seed=spec.seed if spec.simulated else None,
                                time_scale=spec.time_scale)
        meta.update(trial=spec.trial, chips=rig.boards[slot.name].settings(),
                    table_url=getattr(rig.table, "url", None), slot={**slot.to_dict(), "table": str(self.folder)})
        if rig.truth_fns:
            try:
                meta["truth"] = rig.truth_fns[slot.name]()
            except DriverError:
                pass
        if plan is not None:
            meta["plan"] = plan
        return meta

    def _drop(self, store: SessionStore, why: str, t: float | None) -> None:
        """A slot is recorded no more: the event and the status say why; its recorded holds stay."""
        try:
            store.log_event(DROPPED_EVENT, why, t)
        except RigError:
            pass
        self._mark(store, "failed", f"dropped: {why}; not calibrated, its recorded holds are kept", slot_dropped=why)

    def _record_slots(self, rig, board: SlotsBoard, stores: dict, schedule: list[Orientation], start: int, *,
                      resumed: bool) -> dict:
        """Record holds `start..` of every live slot; {} when all are recorded, else each live slot's Outcome of
        the stop or fault that ended the session."""
        n = len(schedule)
        fan = SlotStores(stores, board, on_drop=lambda slot, why, t: self._drop(stores[slot], why, t))
        live = fan.live()
        try:
            for name in live:
                stores[name].set_status("running", "resumed" if resumed else "")
            t0 = 0.0
            if resumed:
                lasts = {name: stores[name].last_time() for name in live}
                known = [t for t in lasts.values() if t is not None]
                t0 = max(known) + RESUME_GAP_S if known else 0.0
                for name in live:
                    stores[name].mark_resume(t0, lasts[name], f"rig resume, from hold {start} (held again)")
            if not live:
                return {}
            stats = record(RecordingRig(rig.table, board, rig.clock, rig.config), fan, schedule, start_step=start,
                           session_t0=t0, progress=self.progress)
            for name in fan.live():
                stores[name].update_metadata(acquisition=_added(stores[name].metadata.get("acquisition"), stats))
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", signal.SIGINT)
            reason = f"stopped by {signal_name(signum)}; the table was stopped and disabled"
            fan.live()                  # a slot dropped just before is told so first
            return {name: Outcome(self.folder / name, "aborted", self._mark(stores[name], "aborted", reason),
                                  holds=len(stores[name].completed_holds()), n_holds=n, signum=signum)
                    for name in board.live()}
        except Exception as exc:
            url = getattr(rig.table, "url", None)
            fan.live()
            return {name: SessionOrchestrator(self.folder / name, self.build_rig)._failed(stores[name], exc, n,
                                                                                         url=url)
                    for name in board.live()}
        return {}

    def _finish_slots(self, stores: dict, n_holds: int, ended: dict) -> SlotsOutcome:
        """Each live slot calibrated in its own folder (or the Outcome that ended it); a dropped slot's Outcome
        says why it was dropped; the manifest gets the shared table time and every slot's end."""
        outcome = SlotsOutcome(self.folder)
        times = [t for t in (store.last_time() for store in stores.values()) if t is not None]
        outcome.table_time_s = max(times) if times else None
        table = shared_table(self.folder, len(stores), outcome.table_time_s)
        for name, store in stores.items():
            store.update_metadata(table=table)
            dropped = store.metadata.get("slot_dropped")
            if name in ended:
                outcome.slots[name] = ended[name]
            elif dropped:
                outcome.slots[name] = Outcome(self.folder / name, "failed", store.metadata.get("status_reason", ""),
                                              holds=len(store.completed_holds()), n_holds=n_holds)
            else:
                one = SessionOrchestrator(self.folder / name, self.build_rig, method=self.method, plots=self.plots)
                outcome.slots[name] = one._finish(store, n_holds)
        try:
            manifest = read_manifest(self.folder)
            manifest.update(table_time_s=outcome.table_time_s, ended={
                name: {"status": o.status, "verdict": o.verdict, "reason": o.reason} for name, o in
                outcome.slots.items()})
            write_json(self.folder / MANIFEST, manifest)
        except (RigError, OSError):
            pass
        return outcome

    def _resume_slots(self) -> SlotsOutcome:
        """Every live slot's session continued from the last orientation all of them recorded (held again)."""
        manifest = read_manifest(self.folder)
        try:
            config = config_from_dict(manifest["config"])
            names = [s["name"] for s in manifest["slots"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{self.folder / MANIFEST}: the manifest cannot be read back ({exc})") from None
        with contextlib.ExitStack() as held:
            held.enter_context(session_lock(self.folder))
            stores = {}
            for name in names:
                held.enter_context(session_lock(self.folder / name))
                stores[name] = held.enter_context(SessionStore.open(self.folder / name))
            live = [name for name in names if not stores[name].metadata.get("slot_dropped")]
            if all(stores[name].metadata.get("status") in FINISHED_STATUSES for name in live):
                raise InputError(f"{self.folder}: every slot's session is already finished; nothing to resume")
            first = stores[live[0]] if live else stores[names[0]]
            try:
                schedule = [Orientation(**o) for o in first.metadata["schedule"]]
            except (KeyError, TypeError, ValueError) as exc:
                raise InputError(f"{first.path}: the session's metadata cannot be read back ({exc})") from None
            done = {name: stores[name].completed_holds() for name in live}
            if all(d and max(d) + 1 >= len(schedule) for d in done.values()):
                return self._finish_slots(stores, len(schedule), {})
            start = min(max(d) if d else 0 for d in done.values())
            for name in live:
                stores[name].keep_reserve()
            rig_config = replace(config, slots=tuple(s for s in config.slots if s.name in live))
            spec = RigSpec(bool(manifest.get("simulated")), manifest.get("seed"), manifest.get("time_scale"),
                           int(manifest.get("trial") or 0), run=len(first.resume_times()) + 1)
            with contextlib.ExitStack() as hardware:
                try:
                    hardware.enter_context(table_lock(config.turntable.url))
                    rig = hardware.enter_context(self.build_rig(rig_config, spec))
                    board = self._started(rig.boards)
                except Busy:
                    raise
                except RigError as exc:
                    for name in live:
                        self._mark(stores[name], "failed", f"resume failed before recording: {exc}")
                    raise
                ended = self._record_slots(rig, board, {name: stores[name] for name in live}, schedule, start,
                                           resumed=True)
            return self._finish_slots(stores, len(schedule), ended)

    # -- finishing -------------------------------------------------------------------------------
    def _finish(self, store: SessionStore, n_holds: int) -> Outcome:
        """Calibrate what is recorded, write calibration.json and the report, record status and verdict."""
        meta = store.metadata
        holds = len(store.completed_holds())
        try:
            session = store.to_session_data()
            result = calibrate_session(session, method=self.method, settle_s=0.0)
            truth = meta.get("truth")
            limits = (meta.get("config") or {}).get("limits")
            evaluation = evaluate(session, result.sensors, gravity=session.gravity, field_uT=session.field_uT,
                                  truth=truth, limits=limits)
            verdict = evaluation.verdict
            status = "rejected" if verdict == "FAIL" else "complete"
            reason = ("verdict FAIL: " + "; ".join(evaluation.failing())) if status == "rejected" else ""
            unit = meta.get("unit", {})
            cal_path = write_session_calibration(self.folder, result, gravity=session.gravity,
                                                 field_uT=session.field_uT, unit_serial=unit.get("serial"),
                                                 board=unit.get("board"),
                                                 extra={"session": str(self.folder), "verdict": verdict,
                                                        **({"plan": meta["plan"]} if meta.get("plan") else {}),
                                                        **({"table": meta["table"]} if meta.get("table") else {})},
                                                 session=session)
            report_args = dict(gravity=session.gravity, field_uT=session.field_uT, truth=truth, limits=limits,
                               evaluation=evaluation,
                               metadata={**meta, "status": status, "status_reason": reason, "verdict": verdict})
            report = write_report(self.folder, session, result.sensors, plots=False, **report_args)
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", signal.SIGINT)
            reason = self._mark(store, "aborted", f"stopped by {signal_name(signum)} while calibrating; every hold is "
                                "recorded, `rig resume` calibrates them")
            return Outcome(self.folder, "aborted", reason, holds=holds, n_holds=n_holds, signum=signum)
        except CalibrationError as exc:
            return self._failed(store, exc, n_holds, prefix="the recorded session cannot be calibrated: ")
        except Exception as exc:
            return self._failed(store, exc, n_holds, prefix="calibration: ")
        reason = self._mark(store, status, reason, verdict=verdict, calibration=cal_path.name, report=report.name)
        store.release_reserve()
        figures = self._figures(session, result, report_args, simulated=bool(meta.get("simulated")))
        return Outcome(self.folder, status, reason, verdict=verdict, holds=holds, n_holds=n_holds,
                       summary=list(result.summary), warnings=list(result.warnings) + survived(store) + figures,
                       truth_lines=truth_errors(result.sensors, truth, (meta.get("plan") or {}).get("predicted"))
                       if truth else [],
                       written=[cal_path, report], h_error_pct=h_errors(result.sensors, truth) if truth else {})

    def _figures(self, session, result, report_args: dict, *, simulated: bool) -> list[str]:
        """Draw the report's figures, once the result is written and the status recorded (matplotlib is the slowest
        part of a simulated session); a figure that cannot be drawn is a warning, never the session's end."""
        if not (self.plots if self.plots is not None else not simulated):
            return []
        try:
            write_report(self.folder, session, result.sensors, plots=True, **report_args)
        except KeyboardInterrupt:
            return ["stopped while drawing the report's figures; the result and the report's tables are written"]
        except Exception as exc:
            return [f"the report's figures could not be drawn ({type(exc).__name__}: {exc}); the result and the "
                    "report's tables are written"]
        return []

    # -- status ----------------------------------------------------------------------------------
    def _failed(self, store: SessionStore | None, exc: BaseException, n_holds: int, prefix: str = "",
                url: str | None = None) -> Outcome:
        known = isinstance(exc, (RigError, OSError)) or type(exc).__module__.startswith("drivers")
        log = None if known else self._write_traceback(exc)
        reason = prefix + describe(exc, url) + (f" (traceback in {log})" if log else "")
        holds = 0
        if store is not None:
            reason = self._mark(store, "failed", reason)
            try:
                holds = len(store.completed_holds())
            except RigError:
                pass
        return Outcome(self.folder, "failed", reason, holds=holds, n_holds=n_holds, error=exc, error_log=log)

    def _mark(self, store: SessionStore, status: str, reason: str, **extra) -> str:
        """Record the status; if even that fails, say so in the reason rather than hide the first problem."""
        try:
            store.set_status(status, reason, **extra)
        except RigError as exc:
            return f"{reason} (and the status could not be recorded: {exc})"
        return reason

    def _write_traceback(self, exc: BaseException) -> Path | None:
        path = self.folder / ERROR_LOG
        text = "".join(traceback.format_exception(exc))
        try:
            with open(path, "a") as f:
                f.write(f"--- {dt.datetime.now().astimezone().isoformat(timespec='seconds')}\n{text}")
        except OSError:
            return None
        return path


def describe(exc: BaseException, url: str | None = None) -> str:
    """A fault in one line: its own message for the rig's errors, its kind and message for anything else,
    with the notes attached on the way (e.g. that the table could not be made safe). Where the message tells a
    programmer what to call (the e-stop's "call reset()"), the operator is told the command instead."""
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename + ': ' if exc.filename else ''}{exc.strerror}"
    else:
        text = str(exc) if isinstance(exc, RigError) else f"{type(exc).__name__}: {exc}"
    if "call reset()" in text:
        text = text.replace("call reset()", f"clear it with `rig table --url {url or 'URL'} reset`")
    notes = getattr(exc, "__notes__", None) or []
    return "; ".join([text, *notes])


def _added(before: dict | None, stats: dict) -> dict:
    """Acquisition figures summed over the runs of a session."""
    if not before:
        return dict(stats)
    return {k: before.get(k, 0) + v if isinstance(v, (int, float)) else v for k, v in stats.items()}


SURVIVED = {"read-error": "read error(s) (empty cells)", "hold-repeated": "hold(s) repeated (motion)",
            "redo": "step(s) redone (a knock, a chip reset, a gap in a move)", "resume": "interruption(s) resumed"}


def survived(store: SessionStore) -> list[str]:
    """One line saying which faults the recording went through (kept in the session's events), if any."""
    counts: dict[str, int] = {}
    for event in store.events():
        if event["kind"] in SURVIVED:
            counts[event["kind"]] = counts.get(event["kind"], 0) + 1
    if not counts:
        return []
    return ["recorded through " + ", ".join(f"{n} {SURVIVED[kind]}" for kind, n in counts.items())
            + f"; when and why are in the event table of {store.path}"]


def h_errors(sensors: dict, truth: dict) -> dict[str, float]:
    """Each sensor's H error against the simulator's truth, per cent (Frobenius norm)."""
    out = {}
    for name, cal in sensors.items():
        t = truth["sensors"].get(name)
        if t:
            H = np.array(t["H"])
            out[name] = float(np.linalg.norm(cal.H - H) / np.linalg.norm(H) * 100)
    return out


def truth_errors(sensors: dict, truth: dict, predicted: dict | None = None) -> list[str]:
    """Each sensor's H and B error against the simulator's truth, in per cent (Frobenius norm), beside the
    planner's predicted standard deviation of H where the session was planned."""
    lines = []
    for name, cal in sensors.items():
        t = truth["sensors"].get(name)
        if not t:
            continue
        H, B = np.array(t["H"]), np.array(t["B"])
        eH = np.linalg.norm(cal.H - H) / np.linalg.norm(H) * 100
        eB = np.linalg.norm(cal.B - B) / max(np.linalg.norm(B), 1e-12) * 100
        line = f"{name}: against the simulator's truth: H error {eH:.4f} % (Frobenius), B error {eB:.4f} %"
        if predicted and name in predicted:
            line += f"; planned: H {predicted[name]['H_rel_pct']:.4f} % (predicted RMS)"
        lines.append(line)
    return lines
