"""MkDocs hook: the exit codes' table, generated from `rig.exits.EXIT_TABLE` at build time.

The page `reference/exit-codes.md` holds the marker `<!-- generated: exit-codes -->`. Every code of the `Exit` enum
and 128 + N for each of `STOP_SIGNALS` must have its row in `EXIT_TABLE`, and every row's codes must be one of
those: the build fails (strict) otherwise, so the page says what every code does, or there is no page.
`tests/faults/test_exit_table.py` makes every code of the same table with a real command.
"""

from __future__ import annotations

import signal

from rig import exits

MARKER = "<!-- generated: exit-codes -->"


class Mismatch(Exception):
    """EXIT_TABLE and the codes a command can end with disagree."""


def rows() -> list[tuple[str, str, str, str]]:
    """(code, name, meaning, the session's stored status) for every exit code a command can end with."""
    names = {int(member): f"`{member.name}`" for member in exits.Exit}
    for name in exits.STOP_SIGNALS:
        if hasattr(signal, name):
            names[exits.aborted(int(getattr(signal, name)))] = f"128 + {name}"
    table = {code: (meaning, status) for codes, meaning, status in exits.EXIT_TABLE for code in codes}
    if set(table) != set(names):
        raise Mismatch(f"rig.exits: EXIT_TABLE's codes {sorted(table)} and the codes a command can end with "
                       f"{sorted(names)} differ (missing {sorted(set(names) - set(table))}, extra "
                       f"{sorted(set(table) - set(names))})")
    return [(str(code), names[code], *table[code]) for code in sorted(table)]


def generate() -> str:
    bar = chr(92) + "|"
    table = ["| code | name | meaning | the session's stored status |", "| --- | --- | --- | --- |"]
    table += [f"| {code} | {name} | {meaning.replace('|', bar)} | `{status}` |"
              for code, name, meaning, status in rows()]
    return "\n".join(table)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, generate())
    return markdown
