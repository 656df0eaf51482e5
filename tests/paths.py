"""Where the project's shared material lives: `shared/` beside the repository (override with RIG_SHARED)."""

import os
from pathlib import Path

SHARED = Path(os.environ.get("RIG_SHARED", Path(__file__).resolve().parents[1].parent / "shared"))
