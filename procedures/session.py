"""The pieces of a calibration session the orchestrator (`procedures.orchestrator`) composes: the schedule and
its observability check, the metadata snapshot, and recording with the table made safe in every exit path.
"""

from __future__ import annotations

import json
import platform
import socket
from dataclasses import asdict
from pathlib import Path
from typing import Callable

import numpy as np

from procedures.move_and_hold import MotionSettings, run_session
from procedures.hold_quality import HoldTarget
from rig.schedule import Orientation, plan_orientations, schedule_rotations
from rig import __version__
from rig.calibration.turntable.observability import check_schedule, move_axes_problem
from rig.config import RigConfig
from rig.io.atomic import write_text_atomic


def motion_settings(config: RigConfig) -> MotionSettings:
    s = config.schedule
    return MotionSettings(config.turntable, s, HoldTarget(s.hold_s, s.hold_min_s, s.hold_max_s or 3 * s.hold_s)
                          if s.sequential else None)


def session_metadata(config: RigConfig, schedule: list[Orientation], *, sim: bool, seed: int | None,
                     time_scale: float | None) -> dict:
    return {
        "software": f"rig {__version__}", "python": platform.python_version(), "host": socket.gethostname(),
        "unit": {"serial": config.serial, "board": config.board}, "operator": config.operator,
        "gravity_mps2": config.gravity_mps2, "field_uT": config.field_uT,
        "config": config.to_dict(), "schedule": [asdict(o) for o in schedule],
        "simulated": sim, "seed": seed, "time_scale": time_scale,
    }


def plan_for(config: RigConfig, seed: int | None = None) -> list[Orientation]:
    return plan_orientations(config.schedule.orientations, seed=seed)


def check_plan(config: RigConfig, schedule: list[Orientation]) -> list[str]:
    """Observability problems of the schedule (empty when every axis is excited), before the table moves.

    The accelerometer is checked against gravity; the gyroscope by the rotation axes of the moves, which
    must span all three fixture axes. The magnetometer's field direction is unknown until calibrated, so it
    is not checked here (a schedule that excites the accelerometer on a tumble table excites it too).
    """
    R = schedule_rotations(schedule, config.geometry)
    problems = []
    rep = check_schedule(R, reference_world=(0.0, 0.0, 1.0))
    if not rep.ok:
        problems.append(f"accel: {rep.message}")
    gyro = move_axes_problem(np.einsum("kji,kjl->kil", R[:-1], R[1:]))
    if gyro:
        problems.append(f"gyro: {gyro}")
    return problems


def record(rig, store, schedule: list[Orientation], *, start_step: int = 0, session_t0: float = 0.0,
           progress: Callable[[int, int, str], None] | None = None) -> dict:
    """Run the table and board through `schedule` into `store`; the table is left safe whatever happens.

    If making it safe fails after another failure (or a stop signal), the first one is raised, with a note
    that the table could not be made safe, rather than hidden behind the second.
    """
    try:
        stats = run_session(rig.table, rig.board, rig.clock, store, schedule, rig.config.geometry,
                            motion_settings(rig.config), start_step=start_step, session_t0=session_t0,
                            progress=progress)
    except BaseException as exc:
        try:
            rig.table.make_safe()
        except Exception as safe_exc:
            exc.add_note(f"the table could not be made safe afterwards: {safe_exc}")
        raise
    rig.table.make_safe()
    return stats


def write_json(path: Path, data: dict) -> None:
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")
