"""Where the documentation lives, and its build hooks loaded as MkDocs loads them (by file, not as a package)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
HOOKS = DOCS / "hooks"


def hook(name: str) -> ModuleType:
    """The hook module docs/hooks/<name>.py, freshly loaded."""
    spec = importlib.util.spec_from_file_location(f"rig_docs_hook_{name}", HOOKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def stamp_module() -> ModuleType:
    """benchmarks/stamp.py, loaded by file as a benchmark script imports it."""
    spec = importlib.util.spec_from_file_location("rig_benchmarks_stamp", ROOT / "benchmarks" / "stamp.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
