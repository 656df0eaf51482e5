"""MkDocs hook: the measurements page, generated at build time from `benchmarks/results/<benchmark>.json` alone.

Each results file is a JSON list of runs a benchmark saved with `--save` (benchmarks/stamp.py). The page holds
the marker `<!-- generated: measurements -->`; this hook replaces it with one table per benchmark, newest run
first: every headline figure with its value, date, commit, machine and load. No figure is typed into the docs by
hand. A results file that breaks the layout (not a list, a run without its stamp, a figure that is not flat) fails
the build (strict), naming the file and the run.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

MARKER = "<!-- generated: measurements -->"
ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"
REQUIRED = ("benchmark", "command", "date", "commit", "machine", "load", "figures")


class BadResults(Exception):
    """A results file the page cannot be generated from."""


def load_runs(path: Path) -> list[dict]:
    """The runs of one results file, checked."""
    try:
        runs = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise BadResults(f"{path}: not readable JSON: {e}") from None
    if not isinstance(runs, list) or not runs:
        raise BadResults(f"{path}: must be a non-empty JSON list of runs")
    for i, run in enumerate(runs):
        where = f"{path}: run {i}"
        if not isinstance(run, dict):
            raise BadResults(f"{where}: not a JSON object")
        missing = [key for key in REQUIRED if key not in run]
        if missing:
            raise BadResults(f"{where}: missing {missing} (a run carries {list(REQUIRED)})")
        if run["benchmark"] != path.stem:
            raise BadResults(f"{where}: benchmark {run['benchmark']!r} saved in the file of {path.stem!r}")
        if not isinstance(run["figures"], dict) or not run["figures"]:
            raise BadResults(f"{where}: figures must be a non-empty object")
        for name, value in run["figures"].items():
            if not isinstance(value, (int, float, str, bool)):
                raise BadResults(f"{where}: figure {name!r} = {value!r} is not a number, a string or a bool")
    return runs


def summary_line(benchmark: str) -> str:
    """The first line of the benchmark script's docstring (read, not run), or '' without a script."""
    script = ROOT / "benchmarks" / f"{benchmark}.py"
    if not script.exists():
        return ""
    doc = ast.get_docstring(ast.parse(script.read_text())) or ""
    return " ".join(doc.split("\n\n")[0].split())


def value(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v).replace("|", "\\|")


def load_text(load) -> str:
    if isinstance(load, dict):
        before, after = load.get("before"), load.get("after")
        return f"{before} → {after}" if after is not None else str(before)
    return str(load)


def generate(results: Path = RESULTS) -> str:
    files = sorted(results.glob("*.json")) if results.is_dir() else []
    if not files:
        return "No benchmark has saved a result yet (`python benchmarks/<benchmark>.py --save`)."
    all_runs = {path.stem: load_runs(path) for path in files}
    machines: list[str] = []
    for runs in all_runs.values():
        for run in runs:
            if run["machine"] not in machines:
                machines.append(run["machine"])
    label = {m: f"M{i + 1}" for i, m in enumerate(machines)}
    out = ["Machines:", ""]
    out += [f"- **{label[m]}**: {m}" for m in machines]
    out.append("")
    for benchmark, runs in all_runs.items():
        out += [f"## `{benchmark}`", ""]
        line = summary_line(benchmark)
        if line:
            out += [line, ""]
        commands = sorted({run["command"] for run in runs})
        out += ["Run as " + ", ".join(f"`{c}`" for c in commands) + ".", ""]
        out += ["| figure | value | date (UTC) | commit | machine | load (1 min, before → after) |",
                "| --- | --- | --- | --- | --- | --- |"]
        for run in sorted(runs, key=lambda r: r["date"], reverse=True):
            for name, v in run["figures"].items():
                out.append(f"| `{name}` | {value(v)} | {run['date'].replace('T', ' ').rstrip('Z')} | "
                           f"`{run['commit']}` | {label[run['machine']]} | {load_text(run['load'])} |")
        out.append("")
    return "\n".join(out)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, generate())
    return markdown
