"""The bus budget: wire time of known transfers worked out by hand from the I2C/SPI framing, the select writes of
a switch, `rig plan` refusing a rate a bus cannot carry, and the prediction against a sampler's measured traffic."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivers import HMC5843, ITG3200
from drivers.tca9548a import TCA9548A, MuxChannel
from fixtures.buses import FakeSMBus
from fixtures.chips import ITG3200Emulator
from fixtures.chips.hmc5843 import HMC5843Emulator
from fixtures.chips.tca9548a import FakeTCA9548A
from fixtures.simrig import SimulatedBoard
from fixtures.sources import ConstantSource
from procedures.acquisition import Sampler
from rig import bus_budget
from rig.board import build_board
from rig.bus_budget import (AUX_EVERY, CountingI2C, I2CTransfer, SpiFrame, TickRead, TrafficLog,
                            counting_wiring, refusal, tick_budget, tick_loads)
from rig.clock import SimClock
from rig.commands.plan import StillWorld, simulated_bus_loads
from rig.config import load_config

RIG = [sys.executable, "-m", "rig.cli"]

# SCL periods by hand (UM10204: 8 data bits + ACK per byte; START, repeated START, STOP one period each):
#   ITG-3200 INT_STATUS..GYRO_ZOUT_L burst: S, addr+W, reg, Sr, addr+R, 9 data bytes, P
ITG_BURST = 1 + 9 + 9 + 1 + 9 + 9 * 9 + 1           # 111
#   HMC5843 STATUS read (read_byte_data): S, addr+W, reg, Sr, addr+R, 1 byte, P
HMC_STATUS = 1 + 9 + 9 + 1 + 9 + 9 + 1              # 39
#   HMC5843 6-byte data burst
HMC_DATA = 1 + 9 + 9 + 1 + 9 + 6 * 9 + 1            # 84
#   switch select: S, addr+W, control byte, P
SELECT = 1 + 9 + 9 + 1                               # 20


def gyro_and_mag(clock):
    bus = FakeSMBus(1)
    bus.attach(0x68, ITG3200Emulator(ConstantSource(np.radians([5.0, 0.0, 0.0])), clock))
    bus.attach(0x1E, HMC5843Emulator(ConstantSource(np.array([20.0, 0.0, -40.0])), clock))
    return bus


def test_one_itg3200_sample_is_the_nine_byte_burst_timed_by_hand():
    clock = SimClock()
    log = TrafficLog()
    gyro = ITG3200(CountingI2C(gyro_and_mag(clock), log, "I2C bus 1"), sleep=clock.sleep)
    gyro.start()
    clock.sleep(0.02)
    read = TickRead("gyro", 1, log.during(gyro.read_if_ready))
    (load,) = tick_loads([("I2C bus 1", read, None)], i2c_clock=100_000)
    assert (load.transfers, load.bytes) == (1, 10)
    assert load.worst_tick_s == pytest.approx(ITG_BURST / 100e3, rel=1e-9)
    (fast,) = tick_loads([("I2C bus 1", read, None)], i2c_clock=400_000)
    assert fast.worst_tick_s == pytest.approx(ITG_BURST / 400e3, rel=1e-9)


def test_magnetometer_every_second_tick_gives_mean_and_worst_by_hand():
    clock = SimClock()
    log = TrafficLog()
    bus = CountingI2C(gyro_and_mag(clock), log, "I2C bus 1")
    gyro, mag = ITG3200(bus, sleep=clock.sleep), HMC5843(bus, sleep=clock.sleep)
    gyro.start()
    mag.start()
    clock.sleep(0.05)
    reads = [TickRead("gyro", 1, log.during(gyro.read_if_ready)),
             TickRead("mag", 2, log.during(lambda: (mag.data_ready(), mag.read_raw())))]
    (load,) = tick_loads([("I2C bus 1", r, None) for r in reads])
    assert load.cycle_ticks == 2
    assert load.worst_tick_s == pytest.approx((ITG_BURST + HMC_STATUS + HMC_DATA) / 100e3, rel=1e-9)
    assert load.seconds_per_tick == pytest.approx((2 * ITG_BURST + HMC_STATUS + HMC_DATA) / 2 / 100e3, rel=1e-9)
    assert (load.transfers, load.bytes) == (3, 10 + 2 + 7)


def test_spi_frames_at_the_driver_speed_plus_the_chip_select_overhead():
    read = TickRead("accel", 1, tuple(("SPI bus 0", SpiFrame(3, 1_000_000)) for _ in range(3)))
    (load,) = tick_loads([("I2C bus 1", read, None)])
    assert load.worst_tick_s == pytest.approx(3 * (24e-6 + bus_budget.SPI_FRAME_OVERHEAD_S), rel=1e-9)


def test_four_boards_behind_a_switch_pay_one_select_per_channel_change():
    burst = I2CTransfer(0x68, ((False, 1), (True, 9)))
    reads = [("I2C bus 1", TickRead(f"gyro{ch}", 1, (("I2C bus 1", burst),)), ch) for ch in range(4)]
    (load,) = tick_loads(reads)
    assert load.worst_tick_s == pytest.approx(4 * (ITG_BURST + SELECT) / 100e3, rel=1e-9)
    same_channel = [("I2C bus 1", r, 2) for _, r, _ in reads]
    (steady,) = tick_loads(same_channel)
    assert steady.worst_tick_s == pytest.approx(4 * ITG_BURST / 100e3, rel=1e-9)


def test_the_sampler_reads_aux_as_often_as_the_budget_assumes():
    assert Sampler.aux_every == AUX_EVERY


def write_config(tmp_path, text: str):
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_rig_plan_refuses_a_rate_the_i2c_bus_cannot_carry(tmp_path):
    # bsn at 100 kHz: gyro burst every tick, magnetometer poll + burst every 2nd, temperature (INT_STATUS and
    # TEMP_OUT_H/L in one 3-byte burst) every 10th
    worst_s = (ITG_BURST + HMC_STATUS + HMC_DATA + (1 + 9 + 9 + 1 + 9 + 3 * 9 + 1)) / 100e3
    rate = 500
    assert worst_s * rate > 1
    # the ITG-3200 samples at the rate too: at its default 100 Hz the session's grid would tick at 100 Hz
    path = write_config(tmp_path, f'[unit]\nboard = "bsn"\n[chips.gyro]\nrate_hz = {rate}\n'
                                  f'[schedule]\nrate_hz = {rate}\n')
    out = subprocess.run([*RIG, "plan", "--config", str(path)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    assert "I2C bus 1" in out.stderr and "rate_hz = 500" in out.stderr
    assert f"{np.floor(10 / worst_s) / 10:g} Hz" in out.stderr
    assert f"{worst_s * 1e3:.3g} ms" in out.stderr


def test_rig_plan_accepts_the_default_sim_config_and_prints_load_and_units_per_hour():
    out = subprocess.run([*RIG, "plan"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "I2C bus 1:" in out.stdout and "SPI bus 0:" in out.stdout
    eta = float(out.stdout.split("estimated rig time: ")[1].split(" s")[0])
    per_hour = float(out.stdout.split("units per hour: ")[1].split(" ")[0])
    assert per_hour == pytest.approx(3600 / (eta + 300), rel=0.01)


def test_a_faster_i2c_clock_carries_the_rate(tmp_path):
    slow = load_config(write_config(tmp_path, '[unit]\nboard = "bsn"\n[schedule]\nrate_hz = 500\n'))
    fast = dataclasses.replace(slow, chips={"i2c_clock_hz": 400_000})
    clock = SimClock()
    loads = tick_budget(fast, SimulatedBoard(fast, clock, StillWorld()).wiring(), settle=lambda: clock.sleep(0.01))
    assert refusal(loads, 500) is None
    with pytest.raises(ValueError, match=r"i2c_clock_hz = 250000; allowed: 100000, 400000"):
        load_config(write_config(tmp_path, '[chips]\ni2c_clock_hz = 250000\n'))


def wire_seconds(entries, clock_hz: float) -> float:
    """Wire time of logged transfers, recomputed here from their messages and frames."""
    total = 0.0
    for _, t in entries:
        if isinstance(t, I2CTransfer):
            bits = 2 + sum(9 * (1 + n) for _, n in t.messages) + (len(t.messages) - 1)
            total += bits / clock_hz
        else:
            total += t.length * 8 / t.speed_hz + bus_budget.SPI_FRAME_OVERHEAD_S
    return total


@pytest.mark.parametrize("board", ["bsn", "lsm6dso", "wearable"])
def test_prediction_within_20_percent_of_a_sampler_run(tmp_path, board):
    config = load_config(write_config(tmp_path, f'[unit]\nboard = "{board}"\n'))
    rate = config.schedule.rate_hz
    clock = SimClock()
    predicted = tick_budget(config, SimulatedBoard(config, clock, StillWorld()).wiring(),
                            settle=lambda: clock.sleep(1 / rate))
    clock = SimClock()
    log = TrafficLog()
    wiring = counting_wiring(SimulatedBoard(config, clock, StillWorld()).wiring(), log, *bus_budget.bus_names({}))
    sampler_board = build_board(config.board, wiring, chips=config.chips)
    sampler_board.start()
    sampler = Sampler(sampler_board, clock, rate, config.schedule.mag_every)
    sampler.align_to("gyro")
    ticks = 200
    start = len(log.entries)
    sampler.run(ticks)
    measured = {}
    for name, t in log.entries[start:]:
        measured.setdefault(name, []).append((name, t))
    for load in predicted:
        got = wire_seconds(measured.get(load.bus, []), 100e3) / ticks
        assert got == pytest.approx(load.seconds_per_tick, rel=0.2), load.bus


def test_select_accounting_matches_the_wire_behind_a_real_switch():
    """Two gyros at 0x68 behind the emulated switch, read through MuxChannel: the budget (reads counted above
    the channel, selects added per change) against every transfer the upstream bus carried."""
    clock = SimClock()
    bus = FakeSMBus(1)
    switch = FakeTCA9548A().attach_to(bus, 0x70)
    for ch in (0, 1):
        switch.downstream(ch).attach(0x68, ITG3200Emulator(ConstantSource(np.zeros(3)), clock))
    wire, per_read = TrafficLog(), TrafficLog()
    upstream = CountingI2C(bus, wire, "I2C bus 1")
    mux = TCA9548A(upstream, 0x70)
    gyros = [ITG3200(CountingI2C(MuxChannel(upstream, mux, ch), per_read, "I2C bus 1"), sleep=clock.sleep)
             for ch in (0, 1)]
    for g in gyros:
        g.start()
    clock.sleep(0.01)
    reads = [("I2C bus 1", TickRead(f"gyro{ch}", 1, per_read.during(g.read_if_ready)), ch)
             for ch, g in enumerate(gyros)]
    (load,) = tick_loads(reads)
    start = len(wire.entries)
    ticks = 50
    for _ in range(ticks):
        clock.sleep(0.01)
        for g in gyros:
            g.read_if_ready()
    measured = wire_seconds(wire.entries[start:], 100e3) / ticks
    assert measured == pytest.approx(load.seconds_per_tick, rel=1e-6)
    assert load.seconds_per_tick == pytest.approx(2 * (ITG_BURST + SELECT) / 100e3, rel=1e-9)


LSM6DSO_FOUR_SLOTS = Path(__file__).resolve().parents[2] / "benchmarks" / "lsm6dso-four-slots.toml"
LSM6DSO_GRID_HZ = 104.0         # the LSM6DSO's output rate nearest a 100 Hz request (datasheet ODR table)


def test_rig_plan_budgets_an_lsm6dso_board_at_the_rate_its_session_ticks_at(tmp_path):
    doc_path = tmp_path / "plan.json"
    out = subprocess.run([*RIG, "plan", "--config", str(LSM6DSO_FOUR_SLOTS), "--json", str(doc_path)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "rate_hz = 100.0" in LSM6DSO_FOUR_SLOTS.read_text()
    assert f"bus load at {LSM6DSO_GRID_HZ:g} Hz" in out.stdout
    assert "configured 100 Hz" in out.stdout
    doc = json.loads(doc_path.read_text())
    assert doc["bus_rate_hz"] == pytest.approx(LSM6DSO_GRID_HZ, rel=1e-12)
    (bus,) = doc["bus_load"]
    line = out.stdout.split(f"  {bus['bus']}: ")[1].splitlines()[0]
    assert f"= {bus['worst_tick_s'] * LSM6DSO_GRID_HZ * 100:.1f} %" in line
    assert f"(mean {bus['mean_tick_s'] * LSM6DSO_GRID_HZ * 100:.1f} %)" in line


def test_rig_plan_refuses_a_rate_the_bus_carries_but_not_the_lsm6dso_grid_it_becomes(tmp_path):
    """Three LSM6DSO boards behind the switch at 100 kHz carry 80 Hz, but a session asked for 80 Hz ticks at the
    chips' 104 Hz (the output rate nearest 80), which the bus cannot carry."""
    text = LSM6DSO_FOUR_SLOTS.read_text()
    three = text[:text.index("[[slots]]\nname = \"s4\"")]
    three = three.replace("i2c_clock_hz = 400000", "i2c_clock_hz = 100000").replace("rate_hz = 100.0", "rate_hz = 80.0")
    path = write_config(tmp_path, three)
    (bus,) = simulated_bus_loads(load_config(path))
    assert bus.load(80.0) <= 1.0 < bus.load(LSM6DSO_GRID_HZ)
    out = subprocess.run([*RIG, "plan", "--config", str(path)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 2, out.stdout
    assert "Traceback" not in out.stderr
    assert "rate_hz = 80" in out.stderr and bus.bus in out.stderr
    assert f"{bus.load(LSM6DSO_GRID_HZ) * 100:.0f} % of the 9.62 ms tick at 104 Hz" in out.stderr
    assert f"carries at most {bus.max_rate_hz():g} Hz" in out.stderr
