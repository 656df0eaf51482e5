"""What every benchmark result carries beside its figures: when, on which commit, on which machine, under what load.

A figure without these cannot be compared with another: the project's machines are shared, so the load at the
time is part of the measurement. A benchmark calls `start(name)` before it measures and `report(...)` after:

    run = stamp.start("bench_sim_session")
    ...measure...
    stamp.report(run, figures={"median_wall_s": median}, details={"runs": runs}, save=args.save)

`report` prints one JSON object, `{"benchmark", "command", "date", "commit", "machine", "load", "figures",
...details}`, and with `save` appends it to `benchmarks/results/<benchmark>.json` (a JSON list, oldest run first).
The documentation's measurements page is generated from those files alone (docs/hooks/measurements.py): a figure
reaches the docs only by being measured and saved here. `figures` are the headline numbers, flat (name -> number,
string or bool) with the unit in the name; `details` keep everything else the benchmark measured.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
REQUIRED = ("benchmark", "date", "commit", "machine", "load", "figures")
_ROOT = Path(__file__).resolve().parents[1]


def start(benchmark: str) -> dict:
    """The stamp of a run of `benchmark` about to start: date (UTC), commit, machine, the load before it and the
    command line that ran it."""
    return {"benchmark": benchmark, "command": command_line(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "commit": commit(), "machine": machine(), "load": {"before": load_1min()}}


def report(run: dict, figures: dict, details: dict | None = None, *, save: bool = False) -> dict:
    """The run's result (its stamp, the load after, `figures`, `details`): printed as JSON, appended to its
    results file when `save`. Refuses figures that are not flat, so the generated tables can show them."""
    for name, value in figures.items():
        if not isinstance(value, (int, float, str, bool)) or isinstance(value, float) and value != value:
            raise ValueError(f"figure {name!r} = {value!r}: a figure is a number, a string or a bool")
    result = {**run, "load": {**run["load"], "after": load_1min()}, "figures": dict(figures), **(details or {})}
    print(json.dumps(result, indent=2))
    if save:
        path = save_result(result)
        print(f"saved to {path.relative_to(_ROOT)}", flush=True)
    return result


def save_result(result: dict, results: Path = RESULTS) -> Path:
    """Append `result` to `results/<benchmark>.json` (created if missing); the path written."""
    missing = [key for key in REQUIRED if key not in result]
    if missing:
        raise ValueError(f"a benchmark result needs {list(REQUIRED)}; missing {missing}")
    results.mkdir(parents=True, exist_ok=True)
    path = results / f"{result['benchmark']}.json"
    runs = json.loads(path.read_text()) if path.exists() else []
    runs.append(result)
    path.write_text(json.dumps(runs, indent=1) + "\n")
    return path


def add_save_option(parser) -> None:
    """`--save` on a benchmark's argparse parser."""
    parser.add_argument("--save", action="store_true",
                        help="also append the result to benchmarks/results/<benchmark>.json (the docs' tables)")


def command_line() -> str:
    """How this process was started, as a user would type it from the repository's root."""
    script = Path(sys.argv[0]).resolve()
    try:
        script_name = str(script.relative_to(_ROOT))
    except ValueError:
        script_name = sys.argv[0]
    return " ".join(["python", script_name, *sys.argv[1:]])


def commit() -> str:
    """The checked-out commit (short hash), with '+dirty' when tracked files differ from it; 'unknown' outside git."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short=10", "HEAD"], cwd=_ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=_ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def machine() -> str:
    """The machine in one line: CPUs and their model, memory, operating system, Python."""
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = " ".join(line.split(":", 1)[1].split())
                break
    except OSError:
        model = platform.processor()
    memory = ""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                memory = f"{int(line.split()[1]) / 2 ** 20:.0f} GiB"
                break
    except OSError:
        pass
    parts = [f"{os.cpu_count()} CPUs" + (f" ({model})" if model else ""), memory,
             f"{platform.system()} {platform.release().split('-')[0]}", f"Python {platform.python_version()}"]
    return ", ".join(part for part in parts if part)


def load_1min() -> float | None:
    """The 1-minute load average (None where the system has none)."""
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None
