"""`rig compare-rigs` on a lab of simulated rigs: does it name the injected faults, and nothing on clean rigs?

Each trial draws a golden unit (its own sensor models) and calibrates it three times on each rig of four
scenarios (`tests/lab/rig_lab.py`): three clean rigs; two clean rigs and one whose table's inner encoder zero is
0.5 deg off ([sim] table_zero_deg); two clean and one whose table carries a field ([sim] table_field_uT); two
clean and one with a loose holder (the unit seated up to +-1 deg differently every session, [sim]
fixture_play_deg), which disagrees with itself. Sessions: the world model, 12 orientations, 1 s holds at 50 Hz,
written as rig session folders and calibrated by the pipeline; the question is asked of a folder store
(`rig.lab.questions.compare_rigs`, what `rig compare-rigs` runs). A trial is right when exactly the faulty rig
is named with its cause (nothing in the clean scenario).

Usage: python benchmarks/bench_compare_rigs.py [--trials 20] [--save]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import stamp  # noqa: E402  (benchmarks/stamp.py)
from rig.lab.folder_store import FolderStore  # noqa: E402
from rig.lab.questions import compare_rigs  # noqa: E402
from tests.lab.rig_lab import FAULTS, named, trial_lab  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=20)
    stamp.add_save_option(ap)
    args = ap.parse_args()
    run = stamp.start("bench_compare_rigs")
    work = Path(tempfile.mkdtemp(prefix="rig-compare-rigs-"))
    scenarios = ["clean", *FAULTS]
    right = {s: 0 for s in scenarios}
    false_names, missed, wrong = [], [], []
    t0 = time.perf_counter()
    try:
        for trial in range(args.trials):
            for scenario in trial_lab(work / f"trial-{trial:03d}", trial):
                found = named(compare_rigs(FolderStore(scenario["store"]), "GOLD")["findings"])
                right[scenario["name"]] += found == scenario["expected"]
                clean_named = sorted(r for r, _ in found if r != scenario["rig"])
                if clean_named:
                    false_names.append({"trial": trial, "scenario": scenario["name"], "named": clean_named})
                if scenario["expected"] and not scenario["expected"] <= found:
                    (wrong if any(r == scenario["rig"] for r, _ in found) else missed).append(
                        {"trial": trial, "scenario": scenario["name"], "found": sorted(found)})
            shutil.rmtree(work / f"trial-{trial:03d}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    seconds = time.perf_counter() - t0
    figures = {"trials": args.trials, **{f"{s}_right": right[s] for s in scenarios},
               "clean_rigs_falsely_named": len(false_names), "faults_missed": len(missed),
               "faults_named_with_another_cause": len(wrong), "seconds": round(seconds, 1)}
    details = {"scenarios": {"misaligned": "[sim] table_zero_deg = [0.0, 0.5]", "magnetic":
                             "[sim] table_field_uT = [1.0, 3.0, 2.0]", "loose": "[sim] fixture_play_deg = 1.0"},
               "sessions_per_rig": 3, "session": "world model, 12 orientations, 1 s holds at 50 Hz",
               "false_names": false_names, "missed": missed, "wrong_cause": wrong}
    stamp.report(run, figures, details, save=args.save)


if __name__ == "__main__":
    main()
