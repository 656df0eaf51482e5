"""Wall time of `rig calibrate --from` (calibrate_from_dir) and of the session read alone; prints JSON.

Session: synthetic, 20 holds with trapezoidal moves between them, accel + gyro at 100 Hz and mag at
50 Hz, ~15 000 rows (tests/io/io_synthetic.py). Targets: read well under 0.5 s, whole command <= 1 s.
Usage: python benchmarks/bench_calibrate_from.py [--repeat N]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "io")]

from io_synthetic import build_session  # noqa: E402

from rig.io.session_csv import read_session  # noqa: E402
from rig.io.session_writer import write_session  # noqa: E402
from rig.pipeline import calibrate_from_dir, calibrate_session  # noqa: E402

HOLD_S = 5.7   # gives ~15 000 rows with the default 20-hold schedule


def best_of(fn, repeat: int) -> tuple[float, float]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), sorted(times)[len(times) // 2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    session, _ = build_session(seed=1, hold_s=HOLD_S)
    with tempfile.TemporaryDirectory() as tmp:
        folder = write_session(session, Path(tmp) / "session")
        out = Path(tmp) / "out"
        loaded = read_session(folder)
        calibrate_from_dir(folder, out, echo=lambda s: None)     # warm-up: imports, caches
        read_min, read_med = best_of(lambda: read_session(folder), args.repeat)
        cal_min, cal_med = best_of(lambda: calibrate_session(loaded), args.repeat)
        total_min, total_med = best_of(lambda: calibrate_from_dir(folder, out, echo=lambda s: None), args.repeat)
        size = (folder / "samples.csv").stat().st_size
    print(json.dumps({
        "benchmark": "calibrate_from_dir",
        "rows": int(len(session.t)), "holds": int(len(session.hold_steps())),
        "sensors": {"accel": "100 Hz", "gyro": "100 Hz", "mag": "50 Hz"},
        "samples_csv_bytes": size, "repeat": args.repeat,
        "read_session_s": {"min": round(read_min, 4), "median": round(read_med, 4), "target": "< 0.5"},
        "calibrate_session_s": {"min": round(cal_min, 4), "median": round(cal_med, 4)},
        "calibrate_from_dir_s": {"min": round(total_min, 4), "median": round(total_med, 4), "target": "<= 1.0"},
    }, indent=2))


if __name__ == "__main__":
    main()
