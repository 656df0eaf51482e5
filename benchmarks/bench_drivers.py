"""Microseconds per driver `read_raw()` on the fake buses and chip emulators; per ADXL312 FIFO burst.

Why: the simulated rig reads every sensor through the real drivers and the register-level emulators, so their
per-read cost bounds how fast a simulated session runs (target <= 15 us per read_raw).

Two figures per driver: `fresh_us` advances the simulated clock by one output period before each read, so every
read makes the emulator produce and quantise a new sample (the clock step's own cost is measured and
subtracted); `cached_us` reads without moving the clock (pure bus + driver path). The source is a
ConstantSource, so the figures exclude the simulator's physics. Best of `--repeat` runs of `--n` reads.

Usage: python benchmarks/bench_drivers.py [--n 20000] [--repeat 5]   (prints JSON)
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fixtures.buses import FakeSMBus, FakeSpiDev  # noqa: E402
from fixtures.chips import (ADXL312Emulator, ADXL330Model, ADXRS453Emulator, HMC1053Model,  # noqa: E402
                            HMC5843Emulator, ITG3200Emulator, MCP3208Emulator)
from fixtures.chips.lsm6dso import LSM6DSOEmulator  # noqa: E402
from drivers.lsm6dso import LSM6DSO  # noqa: E402
from fixtures.sources import AxisOf, ConstantSource  # noqa: E402
from rig.clock import SimClock  # noqa: E402

import drivers  # noqa: E402

G = 9.80665
# Bus transactions one read_raw() makes: the triad reads three gyros, the analog boards one ADC frame per
# channel (HMC1053 with set/reset: three after SET and three after RESET).
TRANSACTIONS = {"adxl312_i2c": 1, "adxl312_spi": 1, "itg3200": 1, "hmc5843": 1, "adxrs453": 1,
                "adxrs453_triad": 3, "adxl330_mcp3208": 3, "hmc1053_mcp3208_set_reset": 6,
                "lsm6dso_i2c_fifo": 2, "lsm6dso_spi_fifo": 2}


def best_us(fn: Callable[[], object], n: int, repeat: int) -> float:
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, time.perf_counter() - t0)
    return best / n * 1e6


def spi(chip, mode: int, speed: int) -> FakeSpiDev:
    dev = FakeSpiDev(chip)
    dev.open(0, 0)
    dev.mode = mode
    dev.max_speed_hz = speed
    return dev


def build(clock: SimClock) -> dict[str, tuple[object, float]]:
    """name -> (started driver, output period in s)."""
    accel = ConstantSource(np.array([0.3, -0.2, G]), temperature=25.0, supply=3.0)
    rate = ConstantSource(np.array([0.01, -0.02, 0.03]), temperature=25.0)
    field = ConstantSource(np.array([20.0, -5.0, 40.0]))
    bus = FakeSMBus(1, devices={0x53: ADXL312Emulator(accel, clock), 0x68: ITG3200Emulator(rate, clock),
                                0x1E: HMC5843Emulator(field, clock)})
    out: dict[str, tuple[object, float]] = {}
    sleep = clock.sleep
    out["adxl312_i2c"] = (drivers.ADXL312(bus, 0x53, sleep=sleep), 0.01)
    out["adxl312_spi"] = (drivers.ADXL312(spi(ADXL312Emulator(accel, clock), 3, 5_000_000), sleep=sleep), 0.01)
    out["itg3200"] = (drivers.ITG3200(bus, 0x68, sleep=sleep), 0.01)
    out["hmc5843"] = (drivers.HMC5843(bus, 0x1E, sleep=sleep), 0.1)
    gyros = [drivers.ADXRS453(spi(ADXRS453Emulator(AxisOf(rate, i), clock), 0, 4_000_000), sleep=sleep)
             for i in range(3)]
    out["adxrs453"] = (gyros[0], 0.001)
    out["adxrs453_triad"] = (drivers.GyroTriad(gyros), 0.001)
    analog_accel = ADXL330Model(accel, clock)
    adc1 = drivers.MCP3208(spi(MCP3208Emulator({i: analog_accel.channel(i) for i in range(3)},
                                               lambda t: accel.supply_v(t), clock), 0, 1_000_000),
                           vref=3.0, sleep=sleep)
    out["adxl330_mcp3208"] = (drivers.ADXL330(adc1, (0, 1, 2), sleep=sleep), 0.001)
    bridge = HMC1053Model(field, clock)
    adc2 = drivers.MCP3208(spi(MCP3208Emulator({3 + i: bridge.channel(i) for i in range(3)}, 3.3, clock),
                               0, 1_000_000), vref=3.3, sleep=sleep)
    out["hmc1053_mcp3208_set_reset"] = (drivers.HMC1053(adc2, (3, 4, 5), bridge.pulse, sleep=sleep), 0.001)
    # LSM6DSO: one read_raw of the gyro view per output period drains the FIFO (status + one burst of the
    # gyro and accel words); the accel view's read that follows in the same tick costs no bus transaction.
    bus.attach(0x6A, LSM6DSOEmulator(accel, rate, clock))
    out["lsm6dso_i2c_fifo"] = (LSM6DSO(bus, 0x6A, sleep=sleep).gyro, 1 / 104)
    out["lsm6dso_spi_fifo"] = (LSM6DSO(spi(LSM6DSOEmulator(accel, rate, clock), 3, 10_000_000), sleep=sleep).gyro,
                               1 / 104)
    for driver, _ in out.values():
        driver.start()
    return out


def bench_fifo(clock: SimClock, n: int, repeat: int, entries: int = 25) -> dict[str, float]:
    accel = ConstantSource(np.array([0.3, -0.2, G]))
    bus = FakeSMBus(1, devices={0x53: ADXL312Emulator(accel, clock)})
    adxl = drivers.ADXL312(bus, 0x53, rate_hz=100, sleep=clock.sleep)
    adxl.start()
    adxl.configure_fifo(entries)
    adxl.read_fifo()
    got = []

    def burst() -> None:
        clock.sleep(entries / 100.0)
        got.append(len(adxl.read_fifo()))

    us = best_us(burst, n, repeat)
    if set(got) != {entries}:
        raise RuntimeError(f"FIFO bursts returned {sorted(set(got))} entries, expected {entries}")
    return {"entries": entries, "us_per_burst": round(us, 2), "us_per_entry": round(us / entries, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    clock = SimClock()
    started = build(clock)
    step_us = {}
    results = {}
    for name, (driver, period) in started.items():
        if period not in step_us:
            step_us[period] = best_us(lambda p=period: clock.sleep(p), args.n, args.repeat)
        cached = best_us(driver.read_raw, args.n, args.repeat)
        fresh = best_us(lambda d=driver, p=period: (clock.sleep(p), d.read_raw()), args.n, args.repeat)
        fresh -= step_us[period]
        results[name] = {"cached_us": round(cached, 2), "fresh_us": round(fresh, 2),
                         "bus_transactions": TRANSACTIONS[name],
                         "fresh_us_per_transaction": round(fresh / TRANSACTIONS[name], 2)}
    fifo = bench_fifo(clock, max(args.n // 10, 100), args.repeat)
    worst = max(r["fresh_us"] for r in results.values())
    print(json.dumps({
        "benchmark": "bench_drivers", "python": platform.python_version(), "n": args.n, "repeat": args.repeat,
        "target_us_per_read": 15.0, "read_raw": results, "adxl312_fifo_read": fifo,
        "worst_fresh_us": worst, "within_target": [k for k, r in results.items() if r["fresh_us"] <= 15.0],
        "over_target": [k for k, r in results.items() if r["fresh_us"] > 15.0],
    }, indent=2))


if __name__ == "__main__":
    main()
