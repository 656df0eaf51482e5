"""Wall time of `rig calibrate --from`: as a whole process on the real recordings in tests/data (imported once with
`rig import`), and in process (calibrate_from_dir) on a synthetic session with the session read timed alone; prints
JSON.

The recordings: imucal's Ferraris session (10 376 rows, six faces and three hand-made turns) and imu_tk's Xsens
recording (51 175 rows, no segments: static intervals detected). A process's time is what a user waits for, start-up
included (median and minimum of --repeat runs, byte-code caches warm).
Synthetic session: 20 holds with trapezoidal moves between them, accel + gyro at 100 Hz and mag at 50 Hz, ~15 000
rows (tests/io/io_synthetic.py). Targets: read well under 0.5 s, whole in-process calibration <= 1 s.
Usage: python benchmarks/bench_calibrate_from.py [--repeat N]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "io"), str(ROOT / "benchmarks")]

from io_synthetic import build_session  # noqa: E402
import stamp  # noqa: E402  (benchmarks/stamp.py)

from rig.io.session_csv import read_session  # noqa: E402
from rig.io.session_writer import write_session  # noqa: E402
from rig.pipeline import calibrate_from_dir, calibrate_session  # noqa: E402

HOLD_S = 5.7   # gives ~15 000 rows with the default 20-hold schedule
DATA = ROOT / "tests" / "data"
RIG = [sys.executable, "-m", "rig.cli"]
RECORDINGS = {
    "imucal-ferraris": ["ferraris", "--csv", DATA / "imucal-ferraris/example_ferraris_session.csv",
                        "--sections", DATA / "imucal-ferraris/example_ferraris_session_list.json",
                        "--rate-hz", "102.4", "--units", "accel=m/s^2,gyro=deg/s"],
    "imu_tk-xsens": ["imu_tk", "--accel", DATA / "imu_tk-xsens/xsens_acc.mat",
                     "--gyro", DATA / "imu_tk-xsens/xsens_gyro.mat"],
}
CACHED = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def best_of(fn, repeat: int) -> tuple[float, float]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), sorted(times)[len(times) // 2]


def run(argv: list) -> None:
    done = subprocess.run([str(a) for a in argv], capture_output=True, text=True, env=CACHED)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, argv))} exited {done.returncode}: {done.stderr.strip()[-400:]}")


def recording_processes(tmp: Path, repeat: int) -> dict:
    """`rig calibrate --from` on each imported recording, as a process."""
    out = {}
    for name, args in RECORDINGS.items():
        folder = tmp / name
        run([*RIG, "import", *args, "--out", folder])
        argv = [*RIG, "calibrate", "--from", folder, "--out", tmp / f"{name}-out"]
        run(argv)                                                       # warm the byte-code caches
        times = []
        for _ in range(repeat):
            shutil.rmtree(tmp / f"{name}-out")                          # a first calibration, not one written over
            t0 = time.perf_counter()
            run(argv)
            times.append(time.perf_counter() - t0)
        out[name] = {"median_s": round(statistics.median(times), 3), "min_s": round(min(times), 3)}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_calibrate_from")
    session, _ = build_session(seed=1, hold_s=HOLD_S)
    with tempfile.TemporaryDirectory() as tmp:
        recordings = recording_processes(Path(tmp), args.repeat)
        folder = write_session(session, Path(tmp) / "session")
        out = Path(tmp) / "out"
        loaded = read_session(folder)
        calibrate_from_dir(folder, out, echo=lambda s: None)     # warm-up: imports, caches
        read_min, read_med = best_of(lambda: read_session(folder), args.repeat)
        cal_min, cal_med = best_of(lambda: calibrate_session(loaded), args.repeat)
        total_min, total_med = best_of(lambda: calibrate_from_dir(folder, out, echo=lambda s: None), args.repeat)
        size = (folder / "samples.csv").stat().st_size
    details = {
        "repeat": args.repeat,
        "recordings_process_s": recordings,
        "synthetic": {
            "rows": int(len(session.t)), "holds": int(len(session.hold_steps())),
            "sensors": {"accel": "100 Hz", "gyro": "100 Hz", "mag": "50 Hz"}, "samples_csv_bytes": size,
            "read_session_s": {"min": round(read_min, 4), "median": round(read_med, 4)},
            "calibrate_session_s": {"min": round(cal_min, 4), "median": round(cal_med, 4)},
            "calibrate_from_dir_s": {"min": round(total_min, 4), "median": round(total_med, 4)},
        },
    }
    figures = {"calibrate_from_dir_median_s": round(total_med, 4), "calibrate_session_median_s": round(cal_med, 4),
               **{f"{name}_process_median_s": r["median_s"] for name, r in recordings.items()}}
    stamp.report(run, figures, details, save=args.save)

if __name__ == "__main__":
    main()
