"""The README stays a short introduction that works: at most 250 lines, the two quick-start commands as they are
run, links and pictures that resolve; and no dated measurement in the README or the docs' prose (measured figures
live in the tables generated from benchmarks/results)."""

from __future__ import annotations

import re

from docs_paths import DOCS, ROOT

README = ROOT / "README.md"
QUICK_START = ("python3 -m venv .venv && . .venv/bin/activate && pip install -q -e . && "
               "rig calibrate --sim --out out/sim", "bash scripts/test.sh")
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
DATE = re.compile(r"\b(?:19|20)\d\d-\d\d-\d\d\b")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def prose(text: str) -> str:
    """Markdown without its fenced code blocks and inline code (examples may hold dates and timestamps)."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", text))


def test_readme_is_short():
    lines = README.read_text().splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines"


def test_readme_quick_start_commands_are_there_verbatim():
    code = "\n".join(block for block in FENCE.findall(README.read_text()))
    for command in QUICK_START:
        assert command in code.splitlines(), f"the quick start lost: {command}"


def test_quick_start_script_exists():
    assert (ROOT / "scripts" / "test.sh").is_file()


def test_readme_links_and_pictures_resolve():
    broken = []
    for target in LINK.findall(README.read_text()):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue
        if not (ROOT / target.split("#")[0]).exists():
            broken.append(target)
    assert not broken, f"README.md links to files that do not exist: {broken}"


def test_no_dated_measurement_in_readme_or_docs_prose():
    pages = [README, *sorted(DOCS.rglob("*.md"))]
    dated = []
    for path in pages:
        for line in prose(path.read_text()).splitlines():
            if DATE.search(line):
                dated.append(f"{path.relative_to(ROOT)}: {line.strip()[:100]}")
    assert not dated, "dates in prose (a measurement belongs in benchmarks/results):\n" + "\n".join(dated)
