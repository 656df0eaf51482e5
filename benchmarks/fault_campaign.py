"""A fault campaign: simulated sessions with faults drawn at random, run as an operator would; prints JSON.

Each session is `rig calibrate --sim --config C --seed U --time-scale X` in a subprocess, then `rig resume` for as
long as a run ends without finishing (at most MAX_RUNS runs), with faults drawn per session (seeded by
--seed and the session's number, the draw recorded):

- in the simulated hardware, through the configuration's [sim.faults] (`fixtures.fault_plan`): Modbus replies
  dropped, delayed, answered with an exception; the fake table's Modbus server stopped and serving again; I2C
  NACK bursts; ADXRS453 parity errors and fault bits; a chip reset to its power-on registers; a knock in a hold;
- from outside: the rig process killed (SIGKILL, SIGTERM, SIGINT) at a random instant, then resumed; the disk
  filling: a small tmpfs mounted for the session (ENOSPC) where this process may mount (root), else a file-size
  limit on the rig process (RLIMIT_FSIZE: EFBIG, in CI), then resumed with room.

Per session: holds lost (committed once, missing later or at the end), holds or moves duplicated (the segments a
session is built from are not each hold once, each move once, in order), exit codes truthful (the code of
every run against rig.exits.EXIT_TABLE, the status it stored and what the faults of that run may
produce), tracebacks seen (stdout, stderr, rig-error.log), every fault fired either survived or reported, and
the H error of each sensor against the same unit's uninterrupted session (the twin, same seed). Beside it the
spread of twin against twin with another noise trial (--twin-trials), since a fault or an interruption
changes the noise realisation even where it changes nothing else. (`benchmarks/resume_twins.py` does the
same comparison in one process, for kills at chosen sensor reads, with no other fault.)

    python benchmarks/fault_campaign.py --sessions 200 [--units 40] [--orientations 12] [--seed 0] [--workers 2]
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import os
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from resume_twins import h_errors  # noqa: E402  (the same H error as the in-process resume benchmark)

KINDS = ("modbus_drop", "modbus_delay", "modbus_exception", "turntable_restart", "kill", "disk_full", "i2c_nack",
         "adxrs453_parity", "adxrs453_fault", "chip_reset", "bump")
BOARDS = ("bsn", "wearable")
I2C_PARTS = {"bsn": ("gyro", "mag"), "wearable": ("accel",)}
RESET_PARTS = {"bsn": ("gyro", "mag"), "wearable": ("accel", "gyro")}
# FAULT bits a sensor-data response shows (FAIL through ST, bits 7:1 in the response); OV, UV and AMP are in the
# FAULT register only, which the driver reads at start, not between samples
FAULT_BITS = (0x800, 0x80, 0x40, 0x20, 0x10, 0x08, 0x04, 0x02)
SIGNALS = ("SIGKILL", "SIGTERM", "SIGINT")
STEP_S = 6.6                  # simulated seconds per orientation (hold, settle, move) of the built-in rig
MAX_RUNS = 5
RUN_TIMEOUT_S = 600
# what a run's message must name for its failure to be the fault's (the fault "reported")
REPORTED = {"modbus_exception": ("exception", "SERVER_DEVICE", "ACKNOWLEDGE"),
            "turntable_restart": ("no valid response", "Connect", "not open"),
            "modbus_drop": ("no valid response", "No response", "CMD_SEQ"),
            "modbus_delay": ("no valid response", "timed out"),
            "i2c_nack": ("no ACK", "Remote I/O"),
            "adxrs453_parity": ("ADXRS453",), "adxrs453_fault": ("ADXRS453",),
            "chip_reset": ("configured", "keeps resetting"),
            "bump": ("kept moving",),
            "disk_full": ("disk", "No space", "file-size limit", "File too large")}
FIRED = {"Modbus request is answered with exception": "modbus_exception", "Modbus server stops": "turntable_restart",
         "NACKs for": "i2c_nack", "parity errors for": "adxrs453_parity", "asserts FAULT": "adxrs453_fault",
         "resets to its power-on": "chip_reset", "a knock on the table": "bump"}


# -- the draw ------------------------------------------------------------------------------------------------
def draw_session(i: int, *, seed: int, units: int, orientations: int, time_scale: float, disk_ways: tuple[str, ...],
                 kinds: tuple[str, ...] = KINDS, primary: str | None = None, extras: bool = True) -> dict:
    """The faults of session `i`, reproducible from (seed, i): a primary kind cycling over `kinds` (so each is
    covered) unless given, and (with `extras`) up to two more at random. A unit's board alternates bsn /
    wearable (the ADXRS453 faults need the wearable board)."""
    rng = np.random.default_rng([seed, i])
    unit = i % units if primary is None or not primary.startswith("adxrs453") else 2 * (i % max(units // 2, 1)) + 1
    board = BOARDS[unit % 2]
    allowed = [k for k in kinds if board == "wearable" or not k.startswith("adxrs453")]
    if not disk_ways:
        allowed = [k for k in allowed if k != "disk_full"]
    primary = primary or allowed[(i // 2) % len(allowed)]
    others = [k for k in allowed if k != primary]
    n_extra = min(int(rng.choice([0, 1, 2], p=[0.4, 0.4, 0.2])), len(others)) if extras else 0
    chosen = [primary, *[str(k) for k in rng.choice(others, n_extra, replace=False)]] if others else [primary]
    t_v = orientations * STEP_S
    wall = 1.5 + orientations * (STEP_S / time_scale + 0.3)

    def instants(k_max: int = 2) -> list[float]:
        return sorted(round(float(rng.uniform(3.0, 0.9 * t_v)), 3) for _ in range(int(rng.integers(1, k_max + 1))))

    sim: dict = {"seed": int(rng.integers(0, 2 ** 31))}
    draw = {"session": i, "unit": unit, "board": board, "kinds": chosen, "sim_faults": sim, "kills": [],
            "disk": None}
    for kind in chosen:
        if kind == "modbus_drop":
            sim["modbus_drop_rate"] = round(float(rng.uniform(0.002, 0.015)), 4)
        elif kind == "modbus_delay":
            sim["modbus_delay_s"] = round(float(rng.uniform(0.002, 0.02)), 4)
        elif kind == "modbus_exception":
            sim["modbus_exception_at_s"] = instants()
            sim["modbus_exception_code"] = int(rng.choice([4, 6]))
        elif kind == "turntable_restart":
            sim["turntable_outage_at_s"] = instants(1)
            sim["turntable_outage_s"] = round(float(rng.uniform(0.05, 0.3) if rng.random() < 0.5
                                                    else rng.uniform(1.0, 5.0)), 3)
        elif kind == "kill":
            draw["kills"] = [{"run": 0, "signal": str(rng.choice(SIGNALS)),
                              "after_s": round(float(rng.uniform(0.6, 0.9 * wall)), 3)}]
            if rng.random() < 0.25:
                draw["kills"].append({"run": 1, "signal": str(rng.choice(SIGNALS)),
                                      "after_s": round(float(rng.uniform(0.6, 0.5 * wall)), 3)})
        elif kind == "disk_full":
            how = str(rng.choice(disk_ways))
            size = rng.uniform(1.4e6, 2.6e6) if how == "tmpfs" else rng.uniform(1.5e5, 1.2e6)
            draw["disk"] = {"how": how, "bytes": int(size)}
        elif kind == "i2c_nack":
            sim["i2c_nack_part"] = str(rng.choice(I2C_PARTS[board]))
            sim["i2c_nack_at_s"] = instants(3)
            sim["i2c_nack_s"] = round(float(rng.uniform(0.005, 0.3) if rng.random() < 0.85
                                            else rng.uniform(1.2, 2.0)), 3)
        elif kind in ("adxrs453_parity", "adxrs453_fault"):
            sim["adxrs453_axis"] = str(rng.choice(["x", "y", "z"]))
            name = "parity" if kind == "adxrs453_parity" else "fault"
            sim[f"adxrs453_{name}_at_s"] = instants(3)
            sim[f"adxrs453_{name}_s"] = round(float(rng.uniform(0.005, 0.3) if rng.random() < 0.85
                                                    else rng.uniform(1.2, 2.0)), 3)
            if name == "fault":
                bits = [b for b in FAULT_BITS if rng.random() < 0.3] or [int(rng.choice(FAULT_BITS))]
                sim["adxrs453_fault_bits"] = int(sum(bits))
        elif kind == "chip_reset":
            sim["chip_reset_part"] = str(rng.choice(RESET_PARTS[board]))
            if sim["chip_reset_part"] == "gyro" and board == "wearable":
                sim.setdefault("adxrs453_axis", str(rng.choice(["x", "y", "z"])))
            sim["chip_reset_at_s"] = instants()
        elif kind == "bump":
            sim["bump_at_s"] = instants()
            sim["bump_amplitude_deg"] = round(float(rng.uniform(0.1, 0.5)), 3)
    return draw


def config_text(board: str, orientations: int, sim_faults: dict | None) -> str:
    """The built-in simulated rig's configuration for `board`, with [sim.faults]."""
    text = resources.files("rig.configs").joinpath("sim.toml").read_text()
    text = text.replace('board = "bsn"', f'board = "{board}"').replace("orientations = 20",
                                                                        f"orientations = {orientations}")
    if sim_faults:
        text += "\n[sim.faults]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in sim_faults.items())
    return text


# -- running the rig as an operator would -----------------------------------------------------------------------
def run_rig(args: list[str], *, env: dict, kill: dict | None = None, fsize: int | None = None) -> dict:
    """One `rig` command in a subprocess; `kill` sends a signal at a random instant, `fsize` limits file sizes."""
    def limit() -> None:
        if fsize is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "rig.cli", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env, preexec_fn=limit)
    sent = None
    if kill is not None:
        try:
            proc.wait(timeout=kill["after_s"])
        except subprocess.TimeoutExpired:
            proc.send_signal(getattr(signal, kill["signal"]))
            sent = kill["signal"]
    try:
        out, err = proc.communicate(timeout=RUN_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        err += "\n[campaign: the run hung and was killed]"
    return {"command": args[0], "rc": proc.returncode, "signal": sent,
            "kill_missed": kill["signal"] if kill is not None and sent is None else None,
            "seconds": round(time.monotonic() - t0, 2), "stdout": out, "stderr": err}


def store_state(folder: Path) -> dict:
    from rig.store import SESSION_FILE

    if not (folder / SESSION_FILE).is_file():
        return {"exists": False}
    try:
        return _store_state(folder)
    except Exception as exc:   # noqa: BLE001 - a session the campaign cannot read is a finding, not a crash
        return {"exists": True, "status": "unreadable", "reason": f"{type(exc).__name__}: {exc}", "holds": []}


def _store_state(folder: Path) -> dict:
    from rig.store import SessionStore
    from rig.store.assemble import used_segments

    with SessionStore.open(folder) as store:
        status, reason = store.status
        meta = store.metadata
        segments = [(phase, step) for _, phase, step in used_segments(store._db)]
        return {"exists": True, "status": status, "reason": reason, "verdict": meta.get("verdict"),
                "holds": store.completed_holds(), "segments": segments, "n": len(meta.get("schedule", [])),
                "moves_stored": [s for (s,) in store._db.execute("SELECT step FROM segment WHERE phase = 'move'")],
                "events": [(e["kind"], e["message"]) for e in store.events() if e["kind"] != "status"]}


def disorder(segments: list[tuple[str, int]], n: int, complete: bool) -> int:
    """How far the segments a session is built from are from: each hold once (a visit and its re-hold after a
    resume or a redo, adjacent), each move once, in order (0 = exactly that)."""
    expected, bad, k = 0, 0, 0
    while k < len(segments):
        phase, step = segments[k]
        if phase != "hold" or step != expected:
            bad += 1
            k += 1
            continue
        while k < len(segments) and segments[k] == ("hold", expected):
            k += 1
        if k < len(segments):
            if segments[k] != ("move", expected):
                bad += 1
            else:
                k += 1
        expected += 1
    return bad + (n - expected if complete else 0)


def check_run(run: dict, before: dict, after: dict) -> dict:
    """Is the run's exit code the one the table promises for how it ended, and what the faults may produce?"""
    rc, sent = run["rc"], run["signal"]
    status = after.get("status")
    text = run["stdout"] + run["stderr"]
    if sent is not None:
        signum = getattr(signal, sent)
        if rc == 0 and status in ("complete",):             # the signal came as the run was ending
            return {"truthful": "verdict:" in run["stdout"], "ended": "finished before the signal"}
        if rc not in (128 + signum, -signum):
            return {"truthful": False, "ended": f"rc {rc} after {sent}"}
        if sent == "SIGKILL" or not after.get("exists"):
            return {"truthful": True, "ended": "killed" if sent == "SIGKILL" else "stopped before recording"}
        ok = status == "aborted" and sent in after.get("reason", "") and "aborted" in run["stderr"]
        if not ok and status in (before.get("status"), "running"):
            ok = "aborted" in run["stderr"]                 # stopped before this run touched the session
        return {"truthful": ok, "ended": "aborted"}
    if rc == 0:
        return {"truthful": status == "complete" and "verdict: PASS" in run["stdout"], "ended": "complete"}
    if rc == 1:
        return {"truthful": status == "rejected" and "verdict: FAIL" in run["stderr"], "ended": "rejected"}
    if rc == 3:
        said = [line for line in run["stderr"].splitlines() if line.strip()]
        ok = bool(said) and (status in ("failed", "running") or not after.get("exists"))
        return {"truthful": ok, "ended": "failed", "message": said[-1][:400] if said else ""}
    return {"truthful": False, "ended": f"rc {rc}", "message": text[-400:]}


def fired_kinds(stderr: str) -> list[str]:
    out = []
    for line in stderr.splitlines():
        if "simulated fault at" in line:
            out += [kind for key, kind in FIRED.items() if key in line]
    return out


def run_session(draw: dict, root: Path, *, orientations: int, time_scale: float, env: dict) -> dict:
    """Run one drawn session to its end (or MAX_RUNS runs) and judge it."""
    work = root / f"s{draw['session']:03d}"
    work.mkdir(parents=True, exist_ok=True)
    (work / "rig.toml").write_text(config_text(draw["board"], orientations, draw["sim_faults"]))
    mounted = None
    disk = draw["disk"]
    if disk and disk["how"] == "tmpfs":
        mounted = work / "disk"
        mounted.mkdir()
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={disk['bytes']}", "tmpfs", str(mounted)], check=True)
    out = (mounted or work) / "session"
    runs, states = [], [{"exists": False}]
    try:
        for k in range(MAX_RUNS):
            kill = next((x for x in draw["kills"] if x["run"] == k), None)
            fsize = disk["bytes"] if disk and disk["how"] == "fsize" and k == 0 else None
            if not states[-1].get("exists"):
                args = ["calibrate", "--sim", "--config", str(work / "rig.toml"), "--seed", str(draw["unit"]),
                        "--time-scale", str(time_scale), "--no-progress", "--out", str(out)]
            else:
                args = ["resume", str(out), "--no-progress"]
            run = run_rig(args, env=env, kill=kill, fsize=fsize)
            if k == 0 and mounted is not None:          # the operator makes room
                subprocess.run(["mount", "-o", "remount,size=256m", str(mounted)], check=True)
            state = store_state(out)
            run.update(check_run(run, states[-1], state), status=state.get("status"),
                       disk_limited=bool(fsize) or (mounted is not None and k == 0),
                       holds=len(state.get("holds", [])), fired=fired_kinds(run["stderr"]),
                       traceback="Traceback" in run["stdout"] + run["stderr"])
            runs.append(run)
            states.append(state)
            if state.get("status") in ("complete", "rejected"):
                break
            if run["ended"] == "failed" and explains_nothing(draw, run):
                break                                   # a failure no fault explains: resuming would not help
        return judge(draw, runs, states, out)
    finally:
        if mounted is not None:
            keep = work / "session-copy"
            if out.exists():
                shutil.copytree(out, keep, dirs_exist_ok=True)
            subprocess.run(["umount", str(mounted)], check=False)


def judge(draw: dict, runs: list[dict], states: list[dict], out: Path) -> dict:
    final = states[-1]
    lost = 0
    for a, b in zip(states[:-1], states[1:]):
        lost += len(set(a.get("holds", [])) - set(b.get("holds", [])))
    complete = final.get("status") == "complete"
    if complete:
        lost += final["n"] - len(set(final["holds"]))
    moves = final.get("moves_stored", [])
    duplicated = len(moves) - len(set(moves)) + disorder(final.get("segments", []), final.get("n", 0), complete)
    tracebacks = sum(r["traceback"] for r in runs) + int((out / "rig-error.log").exists())
    faults = []
    for r in runs:
        for kind in r["fired"]:
            if r["ended"] == "failed":
                verdict = "reported" if any(key in r.get("message", "") for key in REPORTED[kind]) else \
                    "run failed by another fault" if not explains_nothing(draw, r) else "failed, unexplained"
            elif r["ended"] in ("complete", "rejected"):
                verdict = "survived" if r["ended"] == "complete" else "spoiled the calibration"
            else:
                verdict = "interrupted by " + (r["signal"] or r["ended"])
            faults.append({"kind": kind, "outcome": verdict})
    if draw["disk"]:
        faults.append({"kind": "disk_full", "outcome": disk_outcome(draw, runs[0])})
    unexplained = [r.get("message", "") for r in runs if r["ended"] == "failed" and explains_nothing(draw, r)]
    result = {"draw": draw, "status": final.get("status"), "runs": [strip(r) for r in runs], "holds_lost": lost,
              "holds_duplicated": duplicated, "tracebacks": tracebacks,
              "exit_codes_truthful": all(r["truthful"] for r in runs), "faults": faults,
              "unexplained_failures": unexplained, "events": final.get("events", [])[-12:]}
    if complete:
        result["H_error"] = h_errors(out)
    return result


def disk_outcome(draw: dict, run: dict) -> str:
    """What became of the disk limit of a session's first run: the disk filled and the run said so, or the run
    ended before it filled (complete, failed by another fault it names, stopped by a signal)."""
    if run["ended"] == "failed":
        if any(key in run.get("message", "") for key in REPORTED["disk_full"]):
            return "reported"
        return "failed, unexplained" if explains_nothing(draw, run) else "run failed by another fault"
    if run["ended"] in ("complete", "rejected"):
        return "did not fill"
    return "interrupted by " + (run["signal"] or run["ended"])


def explains_nothing(draw: dict, run: dict) -> bool:
    """A failed run whose message names none of the faults active in it."""
    active = set(run["fired"]) | link_kinds(draw) | disk_kind(draw, run)
    return not any(key in run.get("message", "") for kind in active for key in REPORTED[kind])


def link_kinds(draw: dict) -> set[str]:
    sim = draw["sim_faults"]
    return {k for k, key in (("modbus_drop", "modbus_drop_rate"), ("modbus_delay", "modbus_delay_s")) if sim.get(key)}


def disk_kind(draw: dict, run: dict) -> set[str]:
    return {"disk_full"} if run.get("disk_limited") else set()


def strip(run: dict) -> dict:
    """A run as reported: its outcome, and the last lines it printed on stderr."""
    tail = [line for line in run["stderr"].splitlines() if line.strip() and not line.startswith(">>>>>")][-3:]
    return {k: v for k, v in run.items() if k not in ("stdout", "stderr")} | {"stderr_tail": tail}


# -- twins -----------------------------------------------------------------------------------------------------
def twin(unit: int, trial: int, orientations: int, root: str) -> tuple[int, int, dict]:
    """The unit's uninterrupted, fault-free session (trial 0), or one with another noise trial."""
    from procedures.orchestrator import RigSpec, SessionOrchestrator
    from rig.assembly import build_rig
    from rig.config import load_config

    board = BOARDS[unit % 2]
    path = Path(root) / f"twin-{unit}-{trial}.toml"
    path.write_text(config_text(board, orientations, None))
    config = load_config(path)
    folder = Path(root) / f"twin-{unit}-{trial}"
    outcome = SessionOrchestrator(folder, build_rig).start(config, RigSpec(True, unit, None, trial))
    if outcome.status != "complete":
        raise RuntimeError(f"twin {unit}/{trial} did not complete: {outcome.status} {outcome.reason}")
    return unit, trial, h_errors(folder)


# -- the summary -----------------------------------------------------------------------------------------------
def spread(values: list[float]) -> dict:
    if not values:
        return {}
    v = sorted(values)
    return {"n": len(v), "median": round(statistics.median(v), 3), "p90": round(v[int(0.9 * (len(v) - 1))], 3),
            "max": round(v[-1], 3), "above_1.5": sum(x > 1.5 for x in v)}


def summarise(results: list[dict], twins: dict, trials: int) -> dict:
    sensors = ("accel", "gyro", "mag")
    ratio = {s: [] for s in sensors}
    noise = {s: [] for s in sensors}
    high, beyond = [], []
    for unit, errs in twins.items():
        for k in range(1, trials):
            for s in sensors:
                noise[s].append(errs[k][s] / errs[0][s])
    for r in results:
        if "H_error" not in r:
            continue
        errs = twins[r["draw"]["unit"]]
        for s in sensors:
            x = r["H_error"][s] / errs[0][s]
            r.setdefault("H_ratio", {})[s] = round(x, 3)
            ratio[s].append(x)
            band = max(errs[k][s] for k in range(trials))
            if r["H_error"][s] > 1.5 * band:
                beyond.append({"session": r["draw"]["session"], "sensor": s, "error": r["H_error"][s],
                               "worst_noise_trial": band})
            if x > 1.5:
                high.append({"session": r["draw"]["session"], "sensor": s, "ratio": round(x, 3),
                             "within_noise_trials": bool(r["H_error"][s] <= band),
                             "error": r["H_error"][s], "twin_errors": [errs[k][s] for k in range(trials)],
                             "kinds": r["draw"]["kinds"]})
    kinds: dict[str, dict] = {}
    for r in results:
        for kind in r["draw"]["kinds"]:
            kinds.setdefault(kind, {"sessions": 0, "completed": 0})
            kinds[kind]["sessions"] += 1
            kinds[kind]["completed"] += r["status"] == "complete"
        for f in r["faults"]:
            outcome = kinds.setdefault(f["kind"], {"sessions": 0, "completed": 0}).setdefault("fired", {})
            outcome[f["outcome"]] = outcome.get(f["outcome"], 0) + 1
    codes: dict[str, int] = {}
    for r in results:
        for run in r["runs"]:
            codes[str(run["rc"])] = codes.get(str(run["rc"]), 0) + 1
    return {
        "sessions": len(results), "completed": sum(r["status"] == "complete" for r in results),
        "runs": sum(len(r["runs"]) for r in results), "exit_codes": dict(sorted(codes.items())),
        "holds_lost": sum(r["holds_lost"] for r in results),
        "holds_duplicated": sum(r["holds_duplicated"] for r in results),
        "tracebacks": sum(r["tracebacks"] for r in results),
        "exit_codes_untruthful": [r["draw"]["session"] for r in results if not r["exit_codes_truthful"]],
        "unexplained_failures": [r["draw"]["session"] for r in results if r["unexplained_failures"]],
        "faults_neither_survived_nor_reported": [
            {"session": r["draw"]["session"], **f} for r in results for f in r["faults"]
            if f["outcome"] not in ("survived", "reported", "did not fill", "run failed by another fault")
            and not f["outcome"].startswith("interrupted")],
        "not_completed": [r["draw"]["session"] for r in results if r["status"] != "complete"],
        "by_kind": kinds,
        "H_error_ratio_vs_twin": {s: spread(ratio[s]) for s in sensors},
        "H_error_ratio_twin_vs_noise_trial": {s: spread(noise[s]) for s in sensors},
        "ratios_above_1.5": high,
        "beyond_1.5x_worst_noise_trial": beyond,
        "H_error_rank_among_noise_trials": {s: ranks(results, twins, trials, s) for s in sensors},
    }


def ranks(results: list[dict], twins: dict, trials: int, sensor: str) -> dict:
    """Where each completed session's H error falls among its unit's uninterrupted noise trials, for the sessions
    whose noise realisation the faults changed (a redone step, a resumed run, lost reads: the error is not the
    twin's). Harmless faults leave it one more noise trial: ranks uniform on 1..trials+1, mean (trials+2)/2,
    the top rank in 1/(trials+1) of the sessions; a fault that costs accuracy pushes the ranks up."""
    got = []
    for r in results:
        if "H_error" not in r:
            continue
        errs = [twins[r["draw"]["unit"]][k][sensor] for k in range(trials)]
        e = r["H_error"][sensor]
        if abs(e / errs[0] - 1) > 1e-9:
            got.append(1 + sum(x < e for x in errs))
    if not got:
        return {"n": 0}
    return {"n": len(got), "mean_rank": round(statistics.mean(got), 2), "expected_mean": (trials + 2) / 2,
            "top_rank_share": round(sum(g == trials + 1 for g in got) / len(got), 3),
            "expected_top_share": round(1 / (trials + 1), 3)}


def can_mount() -> bool:
    """Whether this process may mount a tmpfs (root, and not forbidden by the container)."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    with tempfile.TemporaryDirectory() as d:
        ok = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", d], capture_output=True).returncode == 0
        if ok:
            subprocess.run(["umount", d], capture_output=True)
        return ok


def run_campaign(*, sessions: int, units: int, orientations: int, seed: int, time_scale: float, workers: int,
                 twin_trials: int, root: Path, kinds: tuple[str, ...] = KINDS, disk_ways: tuple[str, ...] | None = None,
                 first: int = 0, one_each: bool = False) -> dict:
    """The campaign; `one_each`: one session per kind, that fault alone (the small version the tests run)."""
    disk_ways = disk_ways if disk_ways is not None else (("tmpfs", "fsize") if can_mount() else ("fsize",))
    if one_each:
        draws = [draw_session(i, seed=seed, units=units, orientations=orientations, time_scale=time_scale,
                              disk_ways=disk_ways, kinds=kinds, primary=kind, extras=False)
                 for i, kind in enumerate(kinds)]
    else:
        draws = [draw_session(i, seed=seed, units=units, orientations=orientations, time_scale=time_scale,
                              disk_ways=disk_ways, kinds=kinds) for i in range(first, first + sessions)]
    env = {**os.environ, "RIG_LOCK_DIR": str(root / "locks"), "PYTHONPATH": str(ROOT)}
    t0 = time.monotonic()
    used = sorted({d["unit"] for d in draws})
    twins: dict[int, dict[int, dict]] = {}
    with cf.ProcessPoolExecutor(max(1, workers)) as pool:
        for unit, trial, errs in pool.map(twin, *zip(*[(u, k, orientations, str(root)) for u in used
                                                       for k in range(twin_trials)])):
            twins.setdefault(unit, {})[trial] = errs
    t_twins = time.monotonic() - t0
    with cf.ThreadPoolExecutor(max(1, workers)) as pool:
        results = list(pool.map(lambda d: run_session(d, root, orientations=orientations, time_scale=time_scale,
                                                      env=env), draws))
    summary = summarise(results, twins, twin_trials)
    summary.update(seconds=round(time.monotonic() - t0, 1), seconds_twins=round(t_twins, 1),
                   settings={"sessions": len(draws), "first": first, "units": units, "orientations": orientations,
                             "seed": seed, "time_scale": time_scale, "twin_trials": twin_trials,
                             "disk": {"tmpfs": "a tmpfs of the drawn size mounted for the session (ENOSPC)",
                                      "fsize": "RLIMIT_FSIZE on the rig process (EFBIG)"},
                             "disk_ways": list(disk_ways), "kinds": list(kinds)})
    return {"summary": summary, "sessions": results}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sessions", type=int, default=200)
    ap.add_argument("--first", type=int, default=0, help="number of the first session (to rerun a slice)")
    ap.add_argument("--units", type=int, default=40, help="simulated units (seeds); sessions cycle over them")
    ap.add_argument("--orientations", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--time-scale", type=float, default=40.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--twin-trials", type=int, default=5, help="noise trials per unit (trial 0 is the twin)")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--keep", type=Path, default=None, help="keep the session folders here")
    args = ap.parse_args()
    kinds = tuple(k for k in args.kinds.split(",") if k)
    unknown = set(kinds) - set(KINDS)
    if unknown:
        ap.error(f"unknown kinds {sorted(unknown)}; kinds: {', '.join(KINDS)}")
    with tempfile.TemporaryDirectory(prefix="fault-campaign-") as d:
        root = args.keep or Path(d)
        root.mkdir(parents=True, exist_ok=True)
        report = run_campaign(sessions=args.sessions, units=args.units, orientations=args.orientations,
                              seed=args.seed, time_scale=args.time_scale, workers=args.workers,
                              twin_trials=args.twin_trials, root=root, kinds=kinds, first=args.first)
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
