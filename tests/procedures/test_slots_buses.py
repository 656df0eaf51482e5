"""Eight units on two I2C buses at 100 Hz: the bus time a simulated session's transfers used per tick against
`rig plan`'s prediction, every tick of every slot recorded or counted as skipped, and `rig calibrate` refusing a
rate the buses cannot carry before anything moves."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from procedures.orchestrator import RigSpec, SessionOrchestrator
from rig.assembly import assemble_slots
from rig.board import i2c_clock_hz
from rig.bus_budget import WireTimedLog
from rig.commands.plan import simulated_bus_loads
from rig.config import load_config

RIG = [sys.executable, "-m", "rig.cli"]
EIGHT = Path(str(resources.files("rig.configs").joinpath("eight-slots.toml")))


def counted_session(folder: Path, orientations: int = 9, hold_s: float = 0.5, charge: bool = False):
    config = load_config(EIGHT)
    config.schedule.orientations, config.schedule.hold_s = orientations, hold_s
    logs: list[WireTimedLog] = []

    def factory(cfg, spec):
        def traffic(clock):
            logs.append(WireTimedLog(clock, i2c_clock_hz(cfg.chips), charge=charge))
            return logs[-1]
        return assemble_slots(cfg, simulate=True, seed=spec.seed or 0, trial=spec.trial, traffic=traffic)

    outcome = SessionOrchestrator(folder, factory, plots=False).start(config, RigSpec(True, 3))
    return config, outcome, logs[0]


def segments(folder: Path) -> list[tuple[float, float, int]]:
    with sqlite3.connect(folder / "session.sqlite") as db:
        return db.execute("SELECT t_start, t_end, n_rows FROM segment").fetchall()


def acquisition(folder: Path) -> dict:
    with sqlite3.connect(folder / "session.sqlite") as db:
        rows = db.execute("SELECT value FROM metadata WHERE key = 'acquisition' ORDER BY id").fetchall()
    return json.loads(rows[-1][0])


def test_eight_slots_on_two_buses_use_the_bus_time_the_plan_predicted(tmp_path):
    config, outcome, log = counted_session(tmp_path / "eight")
    assert set(outcome.slots) == {f"s{k}" for k in range(1, 9)}
    rate = config.schedule.rate_hz
    predicted = {load.bus: load for load in simulated_bus_loads(config)}
    assert {"I2C bus 1", "I2C bus 2", "SPI bus 0", "SPI bus 1"} <= set(predicted)
    ticks = log.ticks_of(1.0 / rate)
    for bus, load in predicted.items():
        used = np.array([tick.get(bus, 0.0) for tick in ticks])
        assert used.mean() == pytest.approx(load.seconds_per_tick, rel=0.2), bus
        assert np.median(used) <= load.worst_tick_s * 1.2, bus
    for name in outcome.slots:
        figures = acquisition(tmp_path / "eight" / name)
        rows = segments(tmp_path / "eight" / name)
        assert sum(n for _, _, n in rows) + figures["skipped_ticks"] + figures["ticks_discarded"] == figures["ticks"]
        if figures["skipped_ticks"] == 0:
            for t_start, t_end, n in rows:
                assert n == round((t_end - t_start) * rate) + 1, (name, t_start)


def test_with_the_wire_time_paid_eight_slots_keep_the_100_hz_grid(tmp_path):
    """The simulated clock pays each transfer's wire time, as real buses make the sampler wait. The plan says the
    busiest ticks of all four buses, read one after another, fill less than a period (`load` < 1); a tick's reads
    then end within that bus time plus the sampler's wait for the last chip (at most half a period), so the loop
    never falls the half period behind that skips a tick by its own reads. Only the procedure's pauses between
    recordings (reading the chips' configuration back before a hold is stored: a few ms of bus) may cost a tick,
    one at most per move or hold. Every tick is a stored row or counted, no step is spoiled, every slot passes,
    and each bus's time per tick read is the plan's within 20 %."""
    config, outcome, log = counted_session(tmp_path / "paid", charge=True)
    assert log.charge and log.times[-1] > log.times[0]
    rate = config.schedule.rate_hz
    predicted = {load.bus: load for load in simulated_bus_loads(config)}
    assert sum(load.worst_tick_s for load in predicted.values()) * rate < 1.0
    assert {name: o.status for name, o in outcome.slots.items()} == {f"s{k}": "complete" for k in range(1, 9)}
    pauses = 2 * config.schedule.orientations
    for name in outcome.slots:
        figures = acquisition(tmp_path / "paid" / name)
        rows = sum(n for _, _, n in segments(tmp_path / "paid" / name))
        assert rows + figures["skipped_ticks"] + figures["ticks_discarded"] == figures["ticks"], (name, figures)
        assert figures["skipped_ticks"] <= pauses, (name, figures)
        assert figures["steps_redone"] == 0, (name, figures)
    figures = acquisition(tmp_path / "paid" / "s1")
    read = figures["ticks"] - figures["skipped_ticks"]
    for bus, seconds in log.bus_seconds().items():
        assert seconds / read == pytest.approx(predicted[bus].seconds_per_tick, rel=0.2), bus


def test_calibrate_refuses_a_rate_a_bus_cannot_carry_before_anything(tmp_path):
    slow = tmp_path / "eight-100k.toml"
    text = EIGHT.read_text()
    assert "i2c_clock_hz = 400000" in text
    slow.write_text(text.replace("i2c_clock_hz = 400000", "i2c_clock_hz = 100000"))
    loads = {load.bus: load for load in simulated_bus_loads(load_config(slow))}
    bus1 = loads["I2C bus 1"]
    assert bus1.load(100.0) > 1.0
    out = tmp_path / "session"
    res = subprocess.run([*RIG, "calibrate", "--sim", "--config", str(slow), "--no-progress", "--out", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert "I2C bus 1" in res.stderr and "rate_hz = 100" in res.stderr
    assert f"{bus1.load(100.0) * 100:.0f} %" in res.stderr
    assert f"carries at most {bus1.max_rate_hz():g} Hz" in res.stderr
    assert not out.exists() or not any(out.iterdir())
