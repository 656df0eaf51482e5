"""Start-up of the `rig` command as a process: `rig --help` and `rig calibrate --from` on a default session.

Both timed as whole processes, as a user waits for them (median and minimum of --repeat runs), with the slowest
imports of each (python -X importtime), so a change in start-up says where it came from.

Byte-code caches are warm, as in an installed rig after its first run: the children run without
PYTHONDONTWRITEBYTECODE (which some shells and CI set; with it an editable install compiles every rig module
from source on every run, ~0.05 s more) and a first run writes the caches.
Usage: python benchmarks/bench_startup.py [--repeat N]
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

from rig.io.session_writer import write_session  # noqa: E402

RIG = [sys.executable, "-m", "rig.cli"]


CACHED = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def timed(argv: list[str], repeat: int, out: Path | None = None) -> dict:
    """Median and least wall time of `argv` as a process; `out`, the folder it writes, is removed before each run
    (a calibration is not written over another without --force)."""
    times = []
    for _ in range(repeat):
        if out is not None:
            shutil.rmtree(out, ignore_errors=True)
        t0 = time.perf_counter()
        done = subprocess.run(argv, capture_output=True, text=True, env=CACHED)
        times.append(time.perf_counter() - t0)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(argv)} exited {done.returncode}: {done.stderr.strip()[-400:]}")
    return {"median_s": round(statistics.median(times), 4), "min_s": round(min(times), 4)}


def slowest_imports(argv: list[str], top: int = 6) -> list[dict]:
    """The packages whose import cost most: the largest cumulative time of any of their modules (-X importtime)."""
    done = subprocess.run([sys.executable, "-X", "importtime", *argv[1:]], capture_output=True, text=True, env=CACHED)
    totals: dict[str, int] = {}
    for line in done.stderr.splitlines():
        if not line.startswith("import time:") or line.count("|") != 2:
            continue
        _, cumulative, name = (part.strip() for part in line.split("|"))
        if cumulative.isdigit():
            package = name.split(".")[0]
            totals[package] = max(totals.get(package, 0), int(cumulative))
    ranked = sorted(totals.items(), key=lambda kv: -kv[1])[:top]
    return [{"package": name, "ms": round(us / 1000, 1)} for name, us in ranked]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_startup")
    session, _ = build_session(seed=1, hold_s=5.7)
    with tempfile.TemporaryDirectory() as tmp:
        folder = write_session(session, Path(tmp) / "session")
        help_argv = [*RIG, "--help"]
        from_argv = [*RIG, "calibrate", "--from", str(folder), "--out", str(Path(tmp) / "out")]
        subprocess.run(from_argv, capture_output=True, env=CACHED)       # warm the byte-code caches
        result = {
            "help": {**timed(help_argv, args.repeat), "slowest_imports": slowest_imports(help_argv)},
            "calibrate_from": {**timed(from_argv, args.repeat, Path(tmp) / "out"), "rows": int(len(session.t)),
                               "slowest_imports": slowest_imports(from_argv)},
            "repeat": args.repeat,
        }
    figures = {"help_median_s": result["help"]["median_s"],
               "calibrate_from_median_s": result["calibrate_from"]["median_s"]}
    stamp.report(run, figures, {k: v for k, v in result.items() if k != "benchmark"}, save=args.save)


if __name__ == "__main__":
    main()
