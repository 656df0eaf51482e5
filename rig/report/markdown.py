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


LIST_SHOWN = 24          # items of a long list shown in a metadata cell before "... and N more"


def flattened(value, key: str = "", depth: int = 4) -> list[tuple[str, str]]:
    """(dotted key, readable text) rows of a metadata value: nested tables become one row per leaf
    (`config.geometry.outer_axis_world`), lists of numbers stay whole up to LIST_SHOWN items, a list of
    records with the same keys becomes `N x (k1, k2): (v, v), ...`; nothing is cut mid-value."""
    if isinstance(value, dict) and value and depth > 0:
        rows = []
        for k, v in value.items():
            rows += flattened(v, f"{key}.{k}" if key else str(k), depth - 1)
        return rows
    return [(key, readable(value))]


def readable(value) -> str:
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {readable(v)}" for k, v in value.items()) + "}" if value else "{}"
    if isinstance(value, (list, tuple)):
        items = list(value)
        records = [v for v in items if isinstance(v, dict)]
        if items and len(records) == len(items) and all(r.keys() == records[0].keys() for r in records) \
                and all(not isinstance(x, (dict, list)) for r in records for x in r.values()):
            names = list(records[0])
            shown = ["(" + ", ".join(_scalar(r[n]) for n in names) + ")" for r in records[:LIST_SHOWN]]
            more = f", ... and {len(items) - LIST_SHOWN} more" if len(items) > LIST_SHOWN else ""
            return f"{len(items)} x ({', '.join(names)}): " + ", ".join(shown) + more
        shown = [readable(v) for v in items[:LIST_SHOWN]]
        more = f", ... and {len(items) - LIST_SHOWN} more" if len(items) > LIST_SHOWN else ""
        return "[" + ", ".join(shown) + more + "]"
    return _scalar(value)


def _scalar(value) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return number(value, 6)
    return str(value)


def table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)
