"""Where the tests find the real recordings they run on: `tests/data`, each folder with its licence and provenance."""

from pathlib import Path

DATA = Path(__file__).resolve().parent / "data"
DOCS = Path(__file__).resolve().parents[1] / "docs"
