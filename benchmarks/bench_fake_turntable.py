"""Benchmark: round-trip time of the fake turntable per transport (12-register FC03 feedback read).

Run `python -m fixtures.turntable.bench_latency`; prints JSON. (Belongs in benchmarks/; kept here
because this helper owns only fixtures/turntable.)
"""

from __future__ import annotations

import json
import logging
import statistics
import time

from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from rig.clock import RealClock

from fixtures.turntable import FakeTurntable, TurntableServer


CLIENTS = {
    "tcp": lambda srv: ModbusTcpClient("127.0.0.1", port=srv.port, timeout=1),
    "rtu-tcp": lambda srv: ModbusTcpClient("127.0.0.1", port=srv.port, framer=FramerType.RTU, timeout=1),
    # pyserial's socket:// reports in_waiting as 0/1, so pymodbus's serial client reads byte by byte
    "rtu-tcp/serial-client": lambda srv: ModbusSerialClient(f"socket://127.0.0.1:{srv.port}",
                                                            framer=FramerType.RTU, baudrate=115200, timeout=1),
    "rtu-pty": lambda srv: ModbusSerialClient(srv.client_port, framer=FramerType.RTU, baudrate=115200, timeout=1),
}


def measure(case: str, n: int = 200) -> dict:
    transport = case.split("/")[0]
    with TurntableServer(FakeTurntable(RealClock()), transport=transport) as srv:
        c = CLIENTS[case](srv)
        c.connect()
        for _ in range(10):
            c.read_holding_registers(0x0110, count=12, device_id=1)
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            rr = c.read_holding_registers(0x0110, count=12, device_id=1)
            times.append(time.perf_counter() - t0)
            assert not rr.isError()
        c.close()
    ms = sorted(t * 1e3 for t in times)
    return {"case": case, "n": n, "median_ms": round(statistics.median(ms), 3),
            "p95_ms": round(ms[int(0.95 * n) - 1], 3), "max_ms": round(ms[-1], 3)}


def main() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    print(json.dumps({"benchmark": "fake_turntable_fc03_12_registers",
                      "results": [measure(case) for case in CLIENTS]}, indent=1))


if __name__ == "__main__":
    main()
