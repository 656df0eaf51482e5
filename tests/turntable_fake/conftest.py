"""Fixtures for the fake turntable: servers on each transport, raw pymodbus clients.

Addresses below are copied from docs/reference/turntable-map.md on purpose (not imported from the
fake), so a wrong constant in the fake fails these tests.
"""

from __future__ import annotations

import logging

import pytest
from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from fixtures.turntable import FakeTurntable, TurntableServer
from rig.clock import SimClock

AXIS = (0x0100, 0x0200)
ENABLE, COMMAND, TARGET_POS, TARGET_VEL, ACCEL, DECEL = 0x00, 0x01, 0x02, 0x04, 0x06, 0x08
SOFT_LIMIT_POS, SOFT_LIMIT_NEG = 0x0A, 0x0C
FEEDBACK = 0x10
MOVE_ABS, MOVE_REL, MOVE_VEL, STOP, HOME, SET_ZERO, ALARM_RESET = 1, 2, 3, 4, 5, 6, 0x10
ENABLED, MOVING, IN_POSITION, HOMED, HOMING, ALARM, ESTOP, LIMIT_POS, LIMIT_NEG, CMD_REJECTED = (
    1 << k for k in range(10))


@pytest.fixture(autouse=True)
def _quiet_pymodbus():
    """Expected exceptions and dropped frames make pymodbus log loudly; keep test output readable."""
    logger = logging.getLogger("pymodbus")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    yield
    logger.setLevel(level)


@pytest.fixture
def clock() -> SimClock:
    return SimClock(start=100.0)


@pytest.fixture
def tt(clock) -> FakeTurntable:
    return FakeTurntable(clock, encoder_counts_per_rev=2 ** 20, in_position_window_mdeg=5, settle_s=0.2)


def connect(server: TurntableServer, timeout: float = 1.0, retries: int = 0):
    if server.transport == "tcp":
        client = ModbusTcpClient("127.0.0.1", port=server.port, timeout=timeout, retries=retries)
    elif server.transport == "rtu-tcp":
        client = ModbusSerialClient(f"socket://127.0.0.1:{server.port}", framer=FramerType.RTU,
                                    timeout=timeout, retries=retries)
    else:
        client = ModbusSerialClient(server.client_port, framer=FramerType.RTU, baudrate=115200, parity="N",
                                    timeout=timeout, retries=retries)
    assert client.connect(), f"could not connect to {server.url}"
    return client


@pytest.fixture
def server(tt):
    with TurntableServer(tt, transport="tcp") as srv:
        yield srv


@pytest.fixture
def client(server):
    c = connect(server)
    yield c
    c.close()


class Axis:
    """Spec-level access to one axis through a raw pymodbus client."""

    def __init__(self, client, axis: int) -> None:
        self.c, self.base = client, AXIS[axis]

    def write(self, offset: int, value: int):
        return self.c.write_register(self.base + offset, value, device_id=1)

    def write32(self, offset: int, value: int):
        regs = self.c.convert_to_registers(value, self.c.DATATYPE.INT32, word_order="big")
        return self.c.write_registers(self.base + offset, regs, device_id=1)

    def read32(self, offset: int) -> int:
        rr = self.c.read_holding_registers(self.base + offset, count=2, device_id=1)
        assert not rr.isError(), rr
        return self.c.convert_from_registers(rr.registers, self.c.DATATYPE.INT32, word_order="big")

    def profile(self, target: int, speed: int, accel: int, decel: int | None = None):
        values = [target, speed, accel] + ([] if decel is None else [decel])
        regs = [w for v in values for w in self.c.convert_to_registers(v, self.c.DATATYPE.INT32)]
        rr = self.c.write_registers(self.base + TARGET_POS, regs, device_id=1)
        assert not rr.isError(), rr

    def command(self, code: int):
        return self.write(COMMAND, code)

    def feedback(self) -> dict[str, int]:
        """One FC03 of the 12 feedback registers, decoded as the spec says."""
        rr = self.c.read_holding_registers(self.base + FEEDBACK, count=12, device_id=1)
        assert not rr.isError(), rr
        r = rr.registers
        s32 = lambda i: self.c.convert_from_registers(r[i:i + 2], self.c.DATATYPE.INT32)  # noqa: E731
        return {"pos": s32(0), "vel": s32(2), "counts": s32(4), "ferr": s32(6), "status": r[8],
                "alarm": r[9], "last_error": r[10], "seq": r[11]}


@pytest.fixture
def ax0(client) -> Axis:
    return Axis(client, 0)


@pytest.fixture
def ax1(client) -> Axis:
    return Axis(client, 1)
