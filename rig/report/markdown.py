"""Small Markdown helpers: pipe tables whose cells can be parsed back (numbers with 8 significant digits)."""

from __future__ import annotations

import json
import math

import numpy as np


def number(x, digits: int = 8) -> str:
    """A float as text that `float()` reads back; 'n/a' for None or NaN."""
    if x is None:
        return "n/a"
    x = float(x)
    return "n/a" if math.isnan(x) else f"{x:.{digits}g}"


def cell(value) -> str:
    """Any value as one table cell: numbers via `number`, containers as short JSON, pipes escaped."""
    if value is None:
        text = "n/a"
    elif isinstance(value, (bool, np.bool_)):
        text = "yes" if value else "no"
    elif isinstance(value, (int, np.integer)):
        text = str(int(value))
    elif isinstance(value, (float, np.floating)):
        text = number(value)
    elif isinstance(value, (dict, list, tuple)):
        text = json.dumps(value, default=str, separators=(", ", ": "))
        text = text if len(text) <= 120 else text[:117] + "..."
    else:
        text = str(value)
    return text.replace("|", "\\|").replace("\n", " ")


def table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)
