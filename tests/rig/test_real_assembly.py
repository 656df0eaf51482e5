"""The real rig's assembly on the real clock, with the buses opened by injected openers (here: emulated
chips) and the turntable at a URL (here: the fake turntable on loopback, also on real time)."""

import numpy as np

from fixtures.simrig import SimulatedHardware
from procedures.planning import Orientation
from procedures.session import record
from rig.assembly import build_real
from rig.clock import RealClock
from rig.config import load_config
from tests.procedures.test_procedure import MemoryStore

SCHEDULE = [Orientation(10, 0), Orientation(80, 60), Orientation(150, -40), Orientation(60, 140)]


def test_build_real_runs_a_short_session_on_real_time():
    config = load_config()
    config.schedule.hold_s = 0.3
    config.turntable.speed_dps, config.turntable.accel_dps2 = 400.0, 2000.0
    with SimulatedHardware(config, RealClock(), seed=4) as hw:
        config.turntable.url = hw.url
        opened = []

        def open_i2c(n):
            opened.append(("i2c", n))
            return hw.i2c

        def open_spi(bus, cs, mode, hz):
            opened.append(("spi", bus, cs, mode))
            return hw.spi(cs, mode, hz)

        with build_real(config, open_i2c=open_i2c, open_spi=open_spi) as rig:
            assert isinstance(rig.clock, RealClock) and rig.truth_fn is None
            rig.board.start()
            store = MemoryStore()
            record(rig, store, SCHEDULE)
            status = rig.table.status()
    assert ("i2c", 1) in opened and ("spi", 0, 0, 0) in opened
    assert sorted(store.holds) == [0, 1, 2, 3]
    for hold in store.holds.values():
        assert hold["t"].size == 30
        assert not np.isnan(hold["samples"]["gyro"]).any()
    assert all("ENABLED" not in ax.flags for ax in status.axes)
