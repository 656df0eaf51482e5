"""A lab of simulated rigs measuring one golden unit, for `rig compare-rigs`'s tests and its benchmark.

Each rig is a `[sim]` table as a lab engineer would write it in the rig's TOML (`rig.config.SimWorld`: the table's
encoder zeros, a field it carries, a loose holder), read by `rig.config.checked_sim_world` and put into the
simulated world by `fixtures.simrig.world_effects`, the same terms `rig calibrate --sim` puts into it. Sessions
are simulated by the world model (no buses, fast), written as the rig's session folders and calibrated by the
project's pipeline (`archive.write_session`). The analysis then sees only the stored sessions.
"""

from __future__ import annotations

import shutil
import zlib
from pathlib import Path

import numpy as np

from fixtures.simrig import world_effects
from rig.config import checked_sim_world

from .archive import simulated, small_plan, write_session

# What one rig's [sim] table says in each scenario, and what compare-rigs must name on it (None: nothing)
FAULTS = {
    "misaligned": ({"table_zero_deg": [0.0, 0.5]}, "table_misalignment"),
    "magnetic": ({"table_field_uT": [1.0, 3.0, 2.0]}, "magnetic_environment"),
    "loose": ({"fixture_play_deg": 1.0}, "inconsistent"),
}
CLEAN: dict = {}


def rig_sessions(root: Path, rig: str, sim: dict, *, unit: str, unit_seed: int, trial: int, sessions: int,
                 hour: int) -> list[Path]:
    """`sessions` calibrations of the golden unit on `rig`, whose simulated table is the [sim] table `sim`; each
    session draws its own noise and (with fixture play) its own seat of the unit. A session is known by its unit
    and its start: each rig starts its sessions at its own `hour` (0-23) of consecutive days."""
    world = checked_sim_world(sim)
    folders = []
    for k in range(sessions):
        noise_seed = (trial * 7919 + k * 104729 + zlib.crc32(rig.encode())) % 2 ** 31
        effects = world_effects(world, np.random.default_rng([unit_seed, trial, k, zlib.crc32(rig.encode())]))
        plan = small_plan()
        session = simulated(unit_seed, noise_seed, plan, effects)
        folder = root / f"{rig}-{k}"
        write_session(folder, session, unit=unit, rig=rig, plan=plan,
                      start_utc=f"2026-03-{1 + k:02d}T{hour:02d}:00:00.000Z")
        folders.append(folder)
    return folders


def scenario_store(root: Path, parts: list[list[Path]]) -> Path:
    """A folder store holding the session folders of the given rigs (copies: a rig's sessions serve several
    scenarios)."""
    root.mkdir(parents=True)
    for folders in parts:
        for folder in folders:
            shutil.copytree(folder, root / folder.name)
    return root


def named(findings: list[dict]) -> set[tuple[str, str]]:
    """(rig, cause) of every rig compare-rigs named."""
    return {(f["rig"], f["cause"]) for f in findings}


CLEAN_RIGS = ("rig-a", "rig-c", "rig-e")
FAULT_NAMES = ("rig-0", "rig-b", "rig-z")      # sorted before, between and after the clean rigs' names


def trial_lab(root: Path, trial: int, *, sessions: int = 3, unit: str = "GOLD") -> list[dict]:
    """One trial: the golden unit (its own sensor models, drawn from the trial's seed) calibrated `sessions`
    times on three clean rigs and on one rig of each fault of `FAULTS`. The scenarios: the three clean rigs
    (nothing may be named), and for each fault two clean rigs with the faulty one, named so that its place among
    the three moves from trial to trial. Each: its store folder, the faulty rig, and the (rig, cause) expected."""
    unit_seed = 1000 + trial
    position = trial % 3
    made = root / "sessions"
    clean = {r: rig_sessions(made, r, CLEAN, unit=unit, unit_seed=unit_seed, trial=trial, sessions=sessions, hour=i)
             for i, r in enumerate(CLEAN_RIGS)}
    scenarios = [{"name": "clean", "store": scenario_store(root / "clean", list(clean.values())), "rig": None,
                  "expected": set()}]
    for i, (fault, (sim, cause)) in enumerate(FAULTS.items()):
        rig = f"{FAULT_NAMES[position]}-{fault}"
        faulty = rig_sessions(made, rig, sim, unit=unit, unit_seed=unit_seed, trial=trial, sessions=sessions,
                              hour=10 + i)
        store = scenario_store(root / fault, [clean["rig-a"], clean["rig-c"], faulty])
        scenarios.append({"name": fault, "store": store, "rig": rig, "expected": {(rig, cause)}})
    return scenarios
