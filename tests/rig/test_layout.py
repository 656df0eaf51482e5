"""The repository's rooms: the calibration math grouped by what a fit calibrates from, the twin in its own package,
and test helpers that cannot stand in for one another."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MAX_MODULES = 20


def modules(folder: Path) -> list[str]:
    return sorted(p.stem for p in folder.glob("*.py") if p.stem != "__init__")


def test_the_calibration_math_is_in_groups_of_at_most_twenty_modules():
    calibration = ROOT / "rig" / "calibration"
    assert modules(calibration) == [], modules(calibration)
    groups = {p.name: modules(p) for p in calibration.iterdir() if (p / "__init__.py").is_file()}
    assert groups and all(groups.values()), groups
    crowded = {name: len(found) for name, found in groups.items() if len(found) > MAX_MODULES}
    assert not crowded, crowded


def test_the_twin_is_a_package_of_its_own():
    procedures = ROOT / "procedures"
    assert not list(procedures.glob("twin_*.py")), sorted(p.name for p in procedures.glob("twin_*.py"))
    assert modules(procedures / "twin"), "procedures/twin holds no module"


def test_no_two_test_helpers_share_a_name():
    """Test folders put themselves on sys.path, so a helper imported by bare name is whichever was imported first:
    two of one name would serve one folder the other's functions."""
    helpers = [p for p in (ROOT / "tests").rglob("*.py")
               if not p.name.startswith("test_") and p.name not in ("__init__.py", "conftest.py")
               and "data" not in p.relative_to(ROOT / "tests").parts]
    twice = {name: n for name, n in Counter(p.name for p in helpers).items() if n > 1}
    assert not twice, twice


def test_no_two_test_modules_share_a_name():
    """Test folders are not packages, so pytest imports a test file by its bare name: a second file of one name is
    an import mismatch that stops the whole run."""
    tests = [p for p in (ROOT / "tests").rglob("test_*.py") if "data" not in p.relative_to(ROOT / "tests").parts]
    twice = {name: n for name, n in Counter(p.name for p in tests).items() if n > 1}
    assert not twice, twice
