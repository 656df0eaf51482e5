"""A minimal tt-map/1 server for the client's protocol tests (the full fake lives in fixtures/turntable).

`MiniTable` is a pymodbus `SimDevice` whose async action runs a trapezoidal motion model (fixtures.motion)
on an injected clock, validates commands like the map says (02/03/04, CMD_REJECTED, LAST_ERROR, CMD_SEQ)
and can inject faults: lost responses or requests, a stalled axis, command latency (stale IN_POSITION).
"""

from __future__ import annotations

import asyncio
import threading

import pytest
from pymodbus import FramerType
from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from fixtures.motion import AxisTrack
from rig.clock import SimClock

BASES = (0x0100, 0x0200)
ENABLE, COMMAND, TARGET_POS, TARGET_VEL, ACCEL, DECEL = 0x00, 0x01, 0x02, 0x04, 0x06, 0x08
ACTUAL_POS, ACTUAL_VEL, STATUS, ALARM_CODE, LAST_ERROR, CMD_SEQ = 0x10, 0x12, 0x18, 0x19, 0x1A, 0x1B
MOVE_ABS, MOVE_VEL, STOP, HOME, ALARM_RESET = 1, 3, 4, 5, 0x10
KNOWN_COMMANDS = {1, 2, 3, 4, 5, 6, 0x10}


def s32(words: list[int]) -> int:
    v = words[0] << 16 | words[1]
    return v - (1 << 32) if v & 0x80000000 else v


def words32(v: int) -> list[int]:
    v &= 0xFFFFFFFF
    return [v >> 16, v & 0xFFFF]


class MiniAxis:
    def __init__(self, t0: float) -> None:
        self.track = AxisTrack(0.0, t0)
        self.enabled = self.homed = self.rejected = False
        self.seq = self.last_error = self.alarm = 0
        self.target: float | None = 0.0
        self.stalled = False


class MiniTable:
    def __init__(self, clock: SimClock) -> None:
        self.clock = clock
        self.axes = [MiniAxis(clock.now()) for _ in BASES]
        self.estop = False
        self.estop_held = False                # a hard-wired e-stop that a reset cannot clear
        self.alarm_held = 0                    # an axis-0 alarm whose cause persists through a reset
        self.stall_axis: int | None = None     # MOVE_ABS of this axis stops halfway and stays MOVING
        self.command_latency = 0.0             # s between accepting a command and acting on it
        self.drop_command_responses = 0        # COMMAND writes executed, their responses lost
        self.drop_command_requests = 0         # COMMAND writes lost before reaching the table
        self.drop_responses = 0                # any next N responses lost
        self.pending: list[tuple[float, int, int, dict]] = []
        self.commands: list[tuple[int, int]] = []   # (axis, code) as executed
        self._drop_next = False
        blocks = [SimData(0, values=[0x5454, 0x0100, 1, 0], datatype=DataType.REGISTERS, readonly=True),
                  SimData(4, count=2, values=0, datatype=DataType.REGISTERS)]
        for b in BASES:
            blocks += [SimData(b, count=0x0E, values=0, datatype=DataType.REGISTERS),
                       SimData(b + 0x10, count=12, values=0, datatype=DataType.REGISTERS, readonly=True)]
        self.device = SimDevice(1, simdata=blocks, action=self.action)

    # --- wire-level fault hooks (server trace_packet) ---
    def trace_packet(self, sending: bool, data: bytes) -> bytes:
        if sending and (self._drop_next or self.drop_responses > 0):
            if self._drop_next:
                self._drop_next = False
            else:
                self.drop_responses -= 1
            return b""
        return data

    # --- the device ---
    async def action(self, fc, start, address, count, regs, set_values):
        now = self.clock.now()
        self._run_pending(now)
        if set_values is None:
            self._refresh(regs, start, now)
            return None
        get = self._overlay(regs, start, address, set_values)
        for i, addr in enumerate(range(address, address + count)):
            if addr == 5 and set_values[i]:
                self._sys_command(set_values[i], now)
                set_values[i] = 0
            for ax, b in enumerate(BASES):
                if addr == b + ENABLE:
                    self.axes[ax].enabled = bool(set_values[i])
                if addr == b + COMMAND:
                    result = self._command(ax, set_values[i], get, now)
                    set_values[i] = 0
                    if result is not None:
                        self._refresh(regs, start, now)
                        return result
        self._refresh(regs, start, now)
        return None

    @staticmethod
    def _overlay(regs, start, address, set_values):
        def get(addr: int, n: int = 1) -> list[int]:
            return [set_values[a - address] if address <= a < address + len(set_values) else regs[a - start]
                    for a in range(addr, addr + n)]
        return get

    def _sys_command(self, code: int, now: float) -> None:
        if code == 1:
            self.estop = True
            for ax in self.axes:
                ax.track.halt(now)
                ax.target, ax.stalled = None, False
        elif code == 2:
            self.estop = self.estop_held
            for ax in self.axes:
                ax.alarm = 0
            self.axes[0].alarm = self.alarm_held

    def _command(self, i: int, code: int, get, now: float):
        ax, b = self.axes[i], BASES[i]
        if code == 0:
            return None
        if self.drop_command_requests > 0:    # as if the request never arrived: no effect, no answer
            self.drop_command_requests -= 1
            self._drop_next = True
            return None
        if code not in KNOWN_COMMANDS:
            ax.rejected, ax.last_error = True, 3
            return ExcCodes.ILLEGAL_VALUE
        if code != STOP and (self.estop or not ax.enabled or ax.alarm):
            ax.rejected, ax.last_error = True, 1
            return ExcCodes.DEVICE_FAILURE
        params = {"target": s32(get(b + TARGET_POS, 2)) / 1000, "vel": s32(get(b + TARGET_VEL, 2)) / 1000,
                  "accel": s32(get(b + ACCEL, 2)) / 1000, "decel": s32(get(b + DECEL, 2)) / 1000}
        if (code == MOVE_ABS and params["vel"] <= 0) or (code in (MOVE_ABS, MOVE_VEL) and params["accel"] <= 0):
            ax.rejected, ax.last_error = True, 3
            return ExcCodes.ILLEGAL_VALUE
        ax.rejected, ax.last_error = False, 0
        if self.drop_command_responses > 0:
            self.drop_command_responses -= 1
            self._drop_next = True
        self.pending.append((now + self.command_latency, i, code, params))
        self._run_pending(now)
        return None

    def _run_pending(self, now: float) -> None:
        due = [p for p in self.pending if p[0] <= now]
        self.pending = [p for p in self.pending if p[0] > now]
        for t, i, code, params in due:
            self._execute(self.axes[i], i, code, params, t)

    def _execute(self, ax: MiniAxis, i: int, code: int, p: dict, t: float) -> None:
        ax.seq = (ax.seq + 1) & 0xFFFF
        self.commands.append((i, code))
        decel = p["decel"] if p["decel"] > 0 else max(p["accel"], 10.0)
        if code == MOVE_ABS:
            goal = p["target"]
            if self.stall_axis == i:
                goal = 0.5 * (ax.track.state(t)[0] + p["target"])
                ax.stalled = True
            ax.track.move_to(t, goal, p["vel"], p["accel"], decel)
            ax.target = p["target"]
        elif code == MOVE_VEL:
            ax.track.run_at(t, p["vel"], p["accel"])
            ax.target = None
        elif code == STOP:
            ax.track.stop(t, decel)
            ax.target, ax.stalled = None, False
        elif code == HOME:
            ax.track.move_to(t, 0.0, 20.0, 40.0)
            ax.target, ax.homed = 0.0, True

    def _refresh(self, regs, start: int, now: float) -> None:
        regs[2 - start] = (1 if not self.estop else 0) | (2 if self.estop else 0) | (
            4 if any(a.alarm for a in self.axes) else 0)
        regs[3 - start] = int(now * 10) & 0xFFFF
        for ax, b in zip(self.axes, BASES):
            pos, vel, _ = ax.track.state(now)
            moving = now < ax.track.end_time() or vel != 0.0 or ax.stalled
            in_pos = not moving and ax.target is not None and abs(pos - ax.target) < 0.0005
            regs[b + ACTUAL_POS - start: b + ACTUAL_POS - start + 2] = words32(round(pos * 1000))
            regs[b + ACTUAL_VEL - start: b + ACTUAL_VEL - start + 2] = words32(round(vel * 1000))
            regs[b + STATUS - start] = (ax.enabled | moving << 1 | in_pos << 2 | ax.homed << 3
                                        | bool(ax.alarm) << 5 | self.estop << 6 | ax.rejected << 9)
            regs[b + ALARM_CODE - start] = ax.alarm
            regs[b + LAST_ERROR - start] = ax.last_error
            regs[b + CMD_SEQ - start] = ax.seq


class MiniServer:
    """MiniTable on loopback: transport 'tcp' (Modbus TCP) or 'rtu-tcp' (RTU framing over TCP)."""

    def __init__(self, table: MiniTable, transport: str = "tcp") -> None:
        self.table, self.transport = table, transport
        self._ready = threading.Event()
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), daemon=True)

    async def _main(self) -> None:
        framer = FramerType.SOCKET if self.transport == "tcp" else FramerType.RTU
        self.loop = asyncio.get_running_loop()
        self.server = ModbusTcpServer(self.table.device, address=("127.0.0.1", 0), framer=framer,
                                      trace_packet=self.table.trace_packet)
        await self.server.serve_forever(background=True)
        self.port = self.server.transport.sockets[0].getsockname()[1]
        self._ready.set()
        await self.server.serving

    def __enter__(self) -> MiniServer:
        self._thread.start()
        if not self._ready.wait(5):
            raise RuntimeError("test Modbus server did not start")
        return self

    def __exit__(self, *exc) -> None:
        asyncio.run_coroutine_threadsafe(self.server.shutdown(), self.loop).result(5)
        self._thread.join(5)

    @property
    def url(self) -> str:
        return f"{'tcp' if self.transport == 'tcp' else 'rtu+socket'}://127.0.0.1:{self.port}"


@pytest.fixture
def clock() -> SimClock:
    return SimClock()


@pytest.fixture
def table(clock) -> MiniTable:
    return MiniTable(clock)


@pytest.fixture(params=["tcp", "rtu-tcp"])
def server(request, table):
    with MiniServer(table, request.param) as srv:
        yield srv


@pytest.fixture
def tcp_server(table):
    with MiniServer(table, "tcp") as srv:
        yield srv
