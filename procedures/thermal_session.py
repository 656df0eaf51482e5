"""A thermal session: calibration sessions at temperature steps, each after a soak, and one temperature model.

The folder of a thermal session holds its manifest `thermal.json` (`rig-thermal/1`), one ordinary session folder
per step (`step-03-25C/`, run by `SessionOrchestrator`, so each is resumed, calibrated and reported as any
session), and at the end `calibration.json` with each sensor's `temperature_model` (`rig.calibration.thermal`,
written by `rig.io.calibration_json.write_calibration`). For each step not yet done:

1. soak (`procedures.soak`): the chamber to the step's set point, until the die temperature the chips read has
   stopped moving;
2. the step's turntable session at that temperature (the configuration's schedule, `[thermal]` orientations and
   hold_s in place of `[schedule]`'s where given);
3. the step's die temperature (mean and spread of the thermometer over the session's samples) and its rate during
   the holds into the manifest.

With `[thermal] ramp_c_per_min` a ramped step sits on each move between two set points (`rig.config.thermal_steps`):
its approach is a soak at the set point before it, then the chamber ramped towards the set point after it until the
die moves at the ramp's rate (`procedures.ramp`), so that its session runs on the ramp, centred on the move's
middle: the known non-zero die rate a thermal lag needs to be seen.

Resuming (`resume`) continues at the first step not done, always soaking again first: a chamber left safe (or a
new process's simulated one) is back at the room's temperature. A step whose session was interrupted is finished
by the orchestrator's resume. Whatever ends the run (the last step, a fault, a stop signal), the chamber is left
safe (set point to ambient, conditioning off) by the chamber link's `with` block; where even that fails (its link
is down) the reason says so.

Table time is the steps' sessions' table time (`table_time_s` of their calibration.json); chamber time is the
time the chamber was in use: every soak plus every step's session, summed over the runs.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, ContextManager, Protocol

import numpy as np

from procedures.orchestrator import Outcome, RigFactory, RigSpec, SessionOrchestrator
from procedures.session import write_json
from procedures.ramp import RampSettings, ramp_until
from procedures.soak import Soak, SoakSettings, soak
from rig.calibration.thermal import ThermalModel, ThermalStep, fit_thermal_model
from rig.chamber.client import ChamberLink
from rig.chamber.errors import ChamberError, CommunicationError
from rig.clock import Clock
from rig.config import RigConfig, config_from_dict
from rig.config import thermal_steps as session_steps
from rig.discrepancy.thermal import SweptStep, report_lines, thermal_causes
from rig.discrepancy.thermal.sweeps import SAME_SET_POINT_C
from rig.errors import InputError, RigError, signal_name
from rig.io.calibration_json import read_calibration, triads_from_calibration, write_calibration
from rig.locks import session_lock, table_lock
from rig.pipeline.writing import CALIBRATION_FILE
from rig.planner import Plan, applied, eta, plan_for_target
from rig.schedule import plan_orientations
from rig.store import SESSION_FILE, NotASession, SessionStore
from rig.store.schema import utc_now
from rig.store.status import FINISHED_STATUSES

MANIFEST = "thermal.json"
SCHEMA = "rig-thermal/1"
DONE = ("complete", "rejected")


class ThermalHardware(Protocol):
    """What a thermal session runs on: one clock for the chamber and the rig, the rig factory of its steps'
    sessions (and of its soaks, which read the chips' thermometers), and the chamber's link."""

    clock: Clock
    build_rig: RigFactory

    def chamber(self) -> ContextManager[ChamberLink]: ...


# (configuration, spec) -> the hardware of a thermal session as a context manager
HardwareFactory = Callable[[RigConfig, RigSpec], ContextManager[ThermalHardware]]
Events = Callable[[str, dict], None]


class ThermalInputError(InputError):
    """A thermal session cannot be run as configured; nothing was created."""


@dataclass
class ThermalOutcome:
    folder: Path
    status: str                              # complete | rejected | aborted | failed
    reason: str = ""
    verdict: str | None = None
    steps: list[dict] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)     # per-step lines, soak times, the model summary
    warnings: list[str] = field(default_factory=list)
    signum: int | None = None
    error: BaseException | None = None
    error_log: Path | None = None
    written: list[Path] = field(default_factory=list)
    table_time_s: float = 0.0
    chamber_time_s: float = 0.0


def step_folder_name(index: int, set_point_c: float) -> str:
    sign = "m" if set_point_c < 0 else ""
    return f"step-{index + 1:02d}-{sign}{abs(set_point_c):g}C"


def step_plan(config: RigConfig) -> Plan | None:
    """The planner's shortest schedule whose predicted H error (relative RMS, %) meets `[thermal] step_H_std_pct`
    for every sensor; None where [thermal] states its own orientations or no target."""
    t = config.thermal
    if t.orientations or not t.step_H_std_pct:
        return None
    try:
        return plan_for_target(config, t.step_H_std_pct)
    except InputError as exc:
        raise ThermalInputError(f"{config.source}: [thermal] step_H_std_pct: "
                                f"{str(exc).split(': ', 1)[-1]}") from None


def step_config(config: RigConfig) -> RigConfig:
    """A step's session configuration: the planner's schedule (`step_plan`) where [thermal] asks for it, else
    [thermal]'s schedule size and hold in place of [schedule]'s where given."""
    plan = step_plan(config)
    if plan is not None:
        return applied(config, plan)
    t = config.thermal
    schedule = replace(config.schedule, orientations=t.orientations or config.schedule.orientations,
                       hold_s=t.hold_s or config.schedule.hold_s)
    return replace(config, schedule=schedule)


def step_duration_s(config: RigConfig) -> float:
    """A step's predicted table time (`rig.planner.eta` of its schedule), s."""
    c = step_config(config)
    return eta(c, plan_orientations(c.schedule.orientations), c.schedule.hold_s)


def soak_settings(config: RigConfig) -> SoakSettings:
    t, c = config.thermal, config.chamber
    return SoakSettings(slope_c_per_min=t.slope_c_per_min, window_s=t.window_s, poll_s=t.poll_s,
                        min_soak_s=t.min_soak_s, max_soak_s=t.max_soak_s, tolerance_c=c.tolerance_c)


class ThermalSession:
    """Runs one thermal session folder (module docstring); `events(kind, data)` is told each soak and step as it
    ends (the command prints them), `progress` is the steps' orchestrators'."""

    def __init__(self, folder: Path, open_hardware: HardwareFactory, *, method: str = "joint",
                 progress: Callable[[int, int, str], None] | None = None, plots: bool | None = False,
                 events: Events | None = None) -> None:
        self.folder = Path(folder)
        self.open_hardware = open_hardware
        self.method, self.progress, self.plots = method, progress, plots
        self.events = events or (lambda kind, data: None)
        self.manifest: dict = {}

    # -- starting and resuming -------------------------------------------------------------------
    def start(self, config: RigConfig, spec: RigSpec) -> ThermalOutcome:
        if config.thermal is None:
            raise ThermalInputError(f"{config.source}: no [thermal] section; a thermal session needs its steps")
        if config.chamber is None:
            raise ThermalInputError(f"{config.source}: no [chamber] section; a thermal session needs the chamber")
        if config.slots:
            raise ThermalInputError(f"{config.source}: a thermal session of several slots ([[slots]]) is not "
                                    "supported; one unit per thermal session")
        plan = step_plan(config)
        if (self.folder / MANIFEST).exists() or (self.folder / SESSION_FILE).exists():
            raise NotASession(f"{self.folder}: a session already exists here; finish it with `rig resume "
                              f"{self.folder}` or choose another --out")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise NotASession(f"{self.folder}: cannot create the session folder: {exc.strerror}") from None
        planned = session_steps(config.thermal)
        points = [sp for sp, _ in planned]
        self.manifest = {
            "schema": SCHEMA, "created_utc": utc_now(), "status": "running", "status_reason": "",
            "config": config.to_dict(),
            "spec": {"simulated": spec.simulated, "seed": spec.seed, "time_scale": spec.time_scale,
                     "trial": spec.trial},
            "set_points_c": points, "runs": 0, "chamber_time_s": 0.0, "table_time_s": 0.0,
            "steps": [{"index": k, "set_point_c": sp, "ramp_c_per_min": ramp, "folder": step_folder_name(k, sp),
                       "status": "pending", "soaks": []} for k, (sp, ramp) in enumerate(planned)]}
        if plan is not None:
            self.manifest["step_plan"] = {"target_H_std_pct": config.thermal.step_H_std_pct, **plan.to_dict()}
        with session_lock(self.folder):
            self._save()
            return self._run(config, spec)

    def resume(self) -> ThermalOutcome:
        path = self.folder / MANIFEST
        if not path.is_file():
            raise NotASession(f"{self.folder}: no {MANIFEST} here; not a thermal session")
        with session_lock(self.folder):
            try:
                self.manifest = json.loads(path.read_text())
                config = config_from_dict(self.manifest["config"])
                s = self.manifest["spec"]
                spec = RigSpec(bool(s["simulated"]), s.get("seed"), s.get("time_scale"), int(s.get("trial") or 0))
            except (OSError, ValueError, KeyError, TypeError) as exc:
                raise InputError(f"{path}: the thermal session's manifest cannot be read back ({exc})") from None
            if self.manifest.get("status") in FINISHED_STATUSES:
                raise InputError(f"{self.folder}: the thermal session is already finished (status "
                                 f"{self.manifest['status']}, verdict {self.manifest.get('verdict', 'n/a')}); "
                                 "nothing to resume")
            return self._run(config, spec)

    # -- the steps -------------------------------------------------------------------------------
    def _run(self, config: RigConfig, spec: RigSpec) -> ThermalOutcome:
        m = self.manifest
        m["runs"] = int(m.get("runs", 0)) + 1
        self._mark("running", "resumed" if m["runs"] > 1 else "")
        spec = replace(spec, run=m["runs"] - 1)
        outcome: ThermalOutcome | None = None
        try:
            with self.open_hardware(config, spec) as hw:
                try:
                    with hw.chamber() as chamber:
                        chamber.ramp_rate(config.chamber.ramp_c_per_min or None)
                        for step in m["steps"]:
                            if step["status"] in DONE:
                                continue
                            outcome = self._step(config, spec, hw, chamber, step)
                            if outcome is not None:
                                break
                except CommunicationError as exc:
                    exc.add_note("the chamber could not be made safe over its link: switch its conditioning off "
                                 "at its panel")
                    raise
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", 2)
            reason = f"stopped by {signal_name(signum)}; the chamber was made safe, the table stopped and disabled"
            self._mark("aborted", reason)
            return self._outcome("aborted", reason, signum=signum)
        except (RigError, OSError) as exc:
            reason = _describe(exc)
            self._mark("failed", reason)
            return self._outcome("failed", reason, error=exc)
        except Exception as exc:
            self._mark("failed", f"{type(exc).__name__}: {exc}")
            raise
        if outcome is not None:
            return outcome
        return self._finish(config)

    def _step(self, config: RigConfig, spec: RigSpec, hw: ThermalHardware, chamber: ChamberLink,
              step: dict) -> ThermalOutcome | None:
        """Soak and record one step; None when it is done, else the outcome that ends the run."""
        k, n = step["index"], len(self.manifest["steps"])
        step["status"] = "soaking"
        self._save()
        ramp = float(step.get("ramp_c_per_min") or 0.0)
        with table_lock(config.turntable.url), hw.build_rig(config, spec) as rig:
            rig.board.start()
            if ramp:
                done = self._approach_on_ramp(config, hw, chamber, rig.board.read_temperature, step)
            else:
                done = soak(chamber, rig.board.read_temperature, hw.clock, step["set_point_c"],
                            soak_settings(config))
                self._soaked(step, done)
        step["status"] = "recording"
        self._save()
        self.events("soaked", {"step": k, "steps": n, "soak": done})
        folder = self.folder / step["folder"]
        orchestrator = SessionOrchestrator(folder, hw.build_rig, method=self.method, progress=self.progress,
                                           plots=self.plots)
        t0 = hw.clock.now()
        try:
            outcome = self._record_step(orchestrator, folder, config, spec)
        finally:
            self._add_time(hw.clock.now() - t0)
            if ramp:
                chamber.ramp_rate(config.chamber.ramp_c_per_min or None)
        step["status"] = outcome.status
        if outcome.status in DONE:
            step.update(self._step_figures(folder, outcome))
            self._save()
            self.events("step", {"step": k, "steps": n, "data": step, "outcome": outcome})
            return None
        self._save()
        where = f"step {k + 1}/{n} ({step['set_point_c']:g} C, {folder.name})"
        if outcome.status == "aborted":
            reason = f"{where}: {outcome.reason}; the chamber was made safe"
            self._mark("aborted", reason)
            return self._outcome("aborted", reason, signum=outcome.signum)
        reason = f"{where}: {outcome.reason}"
        self._mark("failed", reason)
        return self._outcome("failed", reason, error=outcome.error, error_log=outcome.error_log)

    def _soaked(self, step: dict, done: Soak) -> None:
        self._add_time(done.duration_s)
        step["soaks"].append({"run": self.manifest["runs"], **done.to_dict()})

    def _approach_on_ramp(self, config: RigConfig, hw: ThermalHardware, chamber: ChamberLink,
                          read_die: Callable[[], float | None], step: dict) -> Soak:
        """A ramped step's approach: soaked at the set point before it, then the chamber ramped towards the set
        point after it until the die moves at the ramp's rate, timed so that the step's schedule runs centred on
        the step's temperature (halfway, in the die's own reading: the die at the first set point plus half the
        move); both kept in the step's `soaks`."""
        steps = self.manifest["steps"]
        k, rate = step["index"], float(step["ramp_c_per_min"])
        from_c, to_c = steps[k - 1]["set_point_c"], steps[k + 1]["set_point_c"]
        settled = soak(chamber, read_die, hw.clock, from_c, soak_settings(config))
        self._soaked(step, settled)
        self._save()
        planned = self.manifest.get("step_plan")
        lead_c = 0.5 * abs(rate) / 60.0 * (planned["eta_s"] if planned else step_duration_s(config))
        centre = settled.die_c + (step["set_point_c"] - from_c)
        sign = 1.0 if rate > 0 else -1.0
        t = config.thermal
        settings = RampSettings(rate, t.slope_c_per_min, t.window_s, t.poll_s, t.max_soak_s)
        done = ramp_until(chamber, read_die, hw.clock, to_c, centre - sign * lead_c, centre + sign * lead_c,
                          settings)
        self._soaked(step, done)
        return done

    def _record_step(self, orchestrator: SessionOrchestrator, folder: Path, config: RigConfig,
                     spec: RigSpec) -> Outcome:
        if not (folder / SESSION_FILE).exists():
            return orchestrator.start(step_config(config), replace(spec, run=0))
        with SessionStore.open(folder) as store:
            meta = store.metadata
        if meta.get("status") in FINISHED_STATUSES:        # ended before the manifest was told
            return Outcome(folder, meta["status"], meta.get("status_reason", ""), verdict=meta.get("verdict"))
        return orchestrator.resume()

    def _step_figures(self, folder: Path, outcome: Outcome) -> dict:
        """The step's die temperature (the chips' thermometer over its samples), table time and verdict."""
        with SessionStore.open(folder) as store:
            session = store.to_session_data()
        temp = session.temp_c
        die: dict[str, Any] = {}
        if temp is not None and np.isfinite(temp).any():
            t = temp[np.isfinite(temp)]
            die = {"mean": round(float(t.mean()), 4), "std": round(float(t.std()), 4),
                   "min": round(float(t.min()), 4), "max": round(float(t.max()), 4), "samples": int(t.size)}
            rate = hold_rate_c_per_min(session.t, temp, session.is_move)
            if rate is not None:
                die["rate_c_per_min"] = round(rate, 6)
        table_s = None
        try:
            table_s = read_calibration(folder / CALIBRATION_FILE).get("table_time_s")
        except InputError:
            pass
        if table_s is not None:
            self.manifest["table_time_s"] = round(float(self.manifest.get("table_time_s", 0.0)) + table_s, 3)
        return {"die_c": die, "table_time_s": table_s, "verdict": outcome.verdict}

    # -- the model -------------------------------------------------------------------------------
    def _finish(self, config: RigConfig) -> ThermalOutcome:
        steps = self.manifest["steps"]
        by_sensor: dict[str, list[ThermalStep]] = {}
        recorded: dict[str, list[dict]] = {}
        unit: dict = {}
        cals = {}
        for step in steps:
            folder = self.folder / step["folder"]
            try:
                doc = read_calibration(folder / CALIBRATION_FILE)
            except InputError as exc:
                reason = f"step {step['index'] + 1} ({folder.name}): its calibration cannot be read: {exc}"
                self._mark("failed", reason)
                return self._outcome("failed", reason, error=exc)
            unit = doc.get("unit") or unit
            die = step.get("die_c") or {}
            if "mean" not in die:
                continue
            for name, cal in triads_from_calibration(doc).items():
                by_sensor.setdefault(name, []).append(ThermalStep(die["mean"], cal, die.get("std", 0.0)))
                recorded.setdefault(name, []).append(step)
                cals.setdefault(name, []).append((die["mean"], cal))
        models: dict[str, ThermalModel] = {}
        warnings: list[str] = []
        for name, thermal_steps in by_sensor.items():
            try:
                models[name] = fit_thermal_model(name, thermal_steps)
            except (ValueError, np.linalg.LinAlgError) as exc:
                warnings.append(f"{name}: no temperature model: {exc}")
        sensors = {}
        for name, pairs in cals.items():
            if name in models:
                sensors[name] = models[name].calibration_at(models[name].reference_c)
            else:                                           # the step nearest the middle of the range
                mid = 0.5 * (min(p[0] for p in pairs) + max(p[0] for p in pairs))
                sensors[name] = min(pairs, key=lambda p: abs(p[0] - mid))[1]
        verdicts = [s.get("verdict") for s in steps]
        verdict = "FAIL" if "FAIL" in verdicts else "PASS" if all(v == "PASS" for v in verdicts) else "NOT CHECKED"
        summary = {name: {"reference_c": mdl.reference_c, "valid_c": list(mdl.valid_c),
                          "B_order": mdl.B.orders, "H_order": mdl.H.orders} for name, mdl in models.items()}
        self.manifest["temperature_model"] = summary
        causes = self._causes(by_sensor, recorded)
        self.manifest["causes"] = {name: c.as_dict() for name, c in causes.items()}
        self.manifest["causes_lines"] = [line for c in causes.values() for line in report_lines(c)]
        try:
            path = write_calibration(
                self.folder / CALIBRATION_FILE, sensors, gravity=config.gravity_mps2, field_uT=config.field_uT,
                unit_serial=unit.get("serial"), board=unit.get("board"), temperature_models=models,
                extra={"session": str(self.folder), "verdict": verdict,
                       "table_time_s": self.manifest["table_time_s"],
                       "thermal": {"manifest": MANIFEST, "chamber_time_s": self.manifest["chamber_time_s"],
                                   "steps": [{"set_point_c": s["set_point_c"], "folder": s["folder"],
                                              "die_c": (s.get("die_c") or {}).get("mean")} for s in steps]},
                       "warnings": warnings})
        except (OSError, ValueError) as exc:
            reason = f"the thermal calibration cannot be written: {exc}"
            self._mark("failed", reason)
            return self._outcome("failed", reason, error=exc if isinstance(exc, OSError) else RigError(reason))
        status = "rejected" if verdict == "FAIL" else "complete"
        failing = [s["folder"] for s in steps if s.get("verdict") == "FAIL"]
        reason = f"verdict FAIL at {', '.join(failing)}" if failing else ""
        self.manifest["verdict"] = verdict
        self.manifest["calibration"] = CALIBRATION_FILE
        self._mark(status, reason)
        out = self._outcome(status, reason, verdict=verdict, written=[path])
        out.warnings = warnings
        return out

    def _causes(self, by_sensor: dict[str, list[ThermalStep]], recorded: dict[str, list[dict]]) -> dict:
        """Each sensor's thermal causes (hysteresis between the sweeps, lag of the element behind the
        thermometer) from its steps, each placed in the sweep its die was approached from (`approach_directions`)."""
        out = {}
        for name, thermal_steps in by_sensor.items():
            steps = recorded[name]
            swept = []
            for s, ts, sweep in zip(steps, thermal_steps, approach_directions(steps)):
                air = s["soaks"][-1].get("air_c") if s.get("soaks") else None
                swept.append(SweptStep(ts, sweep, float(s["die_c"].get("rate_c_per_min", 0.0)), air))
            try:
                out[name] = thermal_causes(name, swept)
            except (ValueError, np.linalg.LinAlgError) as exc:
                self.manifest.setdefault("causes_warnings", []).append(f"{name}: no thermal causes: {exc}")
        return out

    # -- the manifest ----------------------------------------------------------------------------
    def _add_time(self, seconds: float) -> None:
        self.manifest["chamber_time_s"] = round(float(self.manifest.get("chamber_time_s", 0.0)) + seconds, 3)

    def _save(self) -> None:
        write_json(self.folder / MANIFEST, self.manifest)

    def _mark(self, status: str, reason: str) -> None:
        self.manifest.update(status=status, status_reason=reason)
        if status != "running":
            self.manifest["end_utc"] = utc_now()
        self._save()

    def _outcome(self, status: str, reason: str, **kw) -> ThermalOutcome:
        m = self.manifest
        return ThermalOutcome(self.folder, status, reason, steps=list(m["steps"]),
                              lines=summary_lines(m), table_time_s=float(m.get("table_time_s", 0.0)),
                              chamber_time_s=float(m.get("chamber_time_s", 0.0)), **kw)


def approach_directions(steps: list[dict]) -> list[str]:
    """Each step's sweep ("up" or "down"): the direction its die temperature moved during the step's last soak
    (from its first reading to its last), the path a hysteresis remembers; where that soak moved the die by less
    than `SAME_SET_POINT_C` or did not keep its first reading, the set-point sequence's (`sweep_directions`). The
    first step of a session is reached from the room's temperature, not from another step, and a resumed step from
    wherever the chamber drifted while it was safe: only the die says which side they were approached from."""
    by_set_points = sweep_directions([s["set_point_c"] for s in steps])
    out = []
    for step, fallback in zip(steps, by_set_points):
        last = step["soaks"][-1] if step.get("soaks") else {}
        moved = float(last.get("die_c", np.nan)) - float(last.get("die_start_c", np.nan))
        out.append(("up" if moved > 0 else "down") if abs(moved) >= SAME_SET_POINT_C else fallback)
    return out


def sweep_directions(set_points: list[float]) -> list[str]:
    """Each step's sweep ("up" or "down") from the set-point sequence: the direction the chamber moved to reach
    it; the first step takes the direction of the move that leaves it."""
    out: list[str] = []
    for k, sp in enumerate(set_points):
        if k > 0 and sp != set_points[k - 1]:
            out.append("up" if sp > set_points[k - 1] else "down")
        elif k + 1 < len(set_points) and set_points[k + 1] != sp:
            out.append("up" if set_points[k + 1] > sp else "down")
        else:
            out.append(out[-1] if out else "up")
    return out


def hold_rate_c_per_min(t: np.ndarray, temp_c: np.ndarray, is_move: np.ndarray) -> float | None:
    """The die temperature's rate during the holds (degC/min, least-squares slope over the hold rows); None
    with fewer than two finite hold readings."""
    ok = np.isfinite(temp_c) & ~np.asarray(is_move, bool) & np.isfinite(t)
    if ok.sum() < 2 or np.ptp(t[ok]) <= 0:
        return None
    return float(np.polyfit(t[ok], temp_c[ok], 1)[0]) * 60.0


def _describe(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename + ': ' if exc.filename else ''}{exc.strerror}"
    else:
        text = str(exc) if isinstance(exc, (RigError, ChamberError)) else f"{type(exc).__name__}: {exc}"
    return "; ".join([text, *(getattr(exc, "__notes__", None) or [])])


def plan_line(plan: dict) -> str:
    """The planner's schedule of every step and its predicted H error against the target."""
    worst = max(p["H_rel_pct"] for p in plan["predicted"].values())
    return (f"each step's schedule (planner, H target {plan['target_H_std_pct']:g} %): {plan['orientations']} "
            f"orientations x {plan['hold_s']:g} s hold, {plan['eta_s']:.0f} s on the table, predicted H error "
            f"{worst:.3g} %")


def step_line(step: dict, n: int) -> str:
    """One line per step: set point, soak, die temperature, table time, verdict."""
    head = f"step {step['index'] + 1}/{n} at {step['set_point_c']:g} C ({step['folder']})"
    parts = []
    if step.get("soaks"):
        last = step["soaks"][-1]
        soaked = sum(s["duration_s"] for s in step["soaks"])
        if step.get("ramp_c_per_min"):
            parts.append(f"ramped at {step['ramp_c_per_min']:+g} C/min after {soaked:.0f} s (die slope "
                         f"{last['die_slope_c_per_min']:+.3f} C/min)")
        else:
            parts.append(f"soaked {soaked:.0f} s (die slope {last['die_slope_c_per_min']:+.3f} C/min"
                         + (f", {len(step['soaks'])} soaks" if len(step["soaks"]) > 1 else "") + ")")
    die = step.get("die_c") or {}
    if "mean" in die:
        parts.append(f"die {die['mean']:.2f} +- {die['std']:.3f} C")
    if step.get("table_time_s") is not None:
        parts.append(f"table {step['table_time_s']:.0f} s")
    parts.append(f"verdict {step['verdict']}" if step.get("verdict") else step["status"])
    return head + ": " + ", ".join(parts)


def summary_lines(manifest: dict) -> list[str]:
    steps = manifest["steps"]
    lines = [plan_line(manifest["step_plan"])] if manifest.get("step_plan") else []
    lines += [step_line(s, len(steps)) for s in steps if s["status"] != "pending"]
    soak_s = sum(x["duration_s"] for s in steps for x in s.get("soaks", []))
    lines.append(f"table time {manifest.get('table_time_s', 0.0):.0f} s; chamber time "
                 f"{manifest.get('chamber_time_s', 0.0):.0f} s (of which soaking {soak_s:.0f} s)")
    for name, mdl in (manifest.get("temperature_model") or {}).items():
        lines.append(f"{name}: temperature model over {mdl['valid_c'][0]:.2f} .. {mdl['valid_c'][1]:.2f} C "
                     f"(reference {mdl['reference_c']:.2f} C), orders B {mdl['B_order']}, H {mdl['H_order']}")
    lines.extend(manifest.get("causes_lines") or [])
    lines.extend(manifest.get("causes_warnings") or [])
    return lines
