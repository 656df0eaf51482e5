"""Reading the Markdown tables of a report back: heading -> rows of {column: cell text}."""

from __future__ import annotations


def tables_by_heading(markdown: str) -> dict[str, list[dict[str, str]]]:
    """The first pipe table under each heading (the heading text without the leading #s)."""
    out: dict[str, list[dict[str, str]]] = {}
    heading, header, rows = None, None, []
    for line in markdown.splitlines() + [""]:
        if line.startswith("#"):
            heading, header = line.lstrip("#").strip(), None
        elif line.startswith("|") and heading is not None and heading not in out:
            cells = [c.strip().replace("\\|", "|") for c in _split(line)]
            if header is None:
                header, rows = cells, []
            elif not all(set(c) <= {"-"} for c in cells):
                rows.append(dict(zip(header, cells)))
        elif header is not None and heading not in out:
            out[heading] = rows
            header = None
    return out


def _split(line: str) -> list[str]:
    """Cells of a table row; `\\|` inside a cell is not a separator."""
    cells, current, i = [], "", 1
    body = line.strip()[1:-1]
    while i <= len(body):
        ch = body[i - 1]
        if ch == "\\" and i < len(body) and body[i] == "|":
            current += "\\|"
            i += 2
            continue
        if ch == "|":
            cells.append(current)
            current = ""
        else:
            current += ch
        i += 1
    cells.append(current)
    return cells


def num(text: str) -> float:
    """A cell as a number; the report writes 'n/a' for a value it could not compute."""
    return float("nan") if text == "n/a" else float(text)


def column(rows: list[dict[str, str]], name: str) -> list[float]:
    return [num(r[name]) for r in rows]


def metric_values(rows: list[dict[str, str]]) -> dict[str, float]:
    """A 'fit quality' table as {metric: value}."""
    return {r["metric"]: num(r["value"]) for r in rows}
