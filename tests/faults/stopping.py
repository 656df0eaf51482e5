"""Stopping a simulated session in this process at a chosen sensor read, as SIGKILL or a stop signal would."""

from __future__ import annotations

import json
import signal
from pathlib import Path

import numpy as np

from rig.commands.common import build_rig
from rig.errors import StopSignal

READS_PER_STEP = 630        # gyro reads of a 5 s hold at 100 Hz and the move after it (about 130)


class Killed(BaseException):
    """Stands for SIGKILL: raised from a sensor read and caught by nothing in the rig, so nothing of the
    session's own handling runs (its status stays "running")."""


def stopping_factory(at_read: int | None = None, how: str = "kill", triad: str = "gyro", glitch=None):
    """A rig factory (orchestrator's `build_rig`) whose `triad` read number `at_read` raises Killed (how="kill")
    or StopSignal (how="SIGINT"/"SIGTERM"/...), or returns `glitch` instead of the sample (how="glitch")."""
    def factory(config, spec):
        rig = build_rig(config, spec)
        if at_read is None:
            return rig
        chip = rig.board.triads[triad]
        read, count = chip.read_raw, [0]

        def stop_here() -> bool:
            count[0] += 1
            if count[0] == at_read:
                if how == "kill":
                    raise Killed()
                if how == "glitch":
                    return True
                raise StopSignal(getattr(signal, how))
            return False

        def read_raw():
            return glitch if stop_here() else read()
        chip.read_raw = read_raw
        if hasattr(chip, "read_if_ready"):      # the sampler reads such a chip's flag and sample in one burst
            burst = chip.read_if_ready

            def read_if_ready():
                value = burst()
                return value if value is None or not stop_here() else glitch
            chip.read_if_ready = read_if_ready
        return rig
    return factory


def h_errors(folder: Path) -> dict[str, float]:
    """Relative Frobenius error of every sensor's H against the simulator's truth."""
    cal = json.loads((folder / "calibration.json").read_text())["sensors"]
    truth = json.loads((folder / "truth.json").read_text())["sensors"]
    return {s: float(np.linalg.norm(np.array(cal[s]["H"]) - np.array(truth[s]["H"])) / np.linalg.norm(truth[s]["H"]))
            for s in cal}
