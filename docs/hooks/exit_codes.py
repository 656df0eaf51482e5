"""MkDocs hook: the exit codes' table, generated from `rig.exits` at build time.

The page `reference/exit-codes.md` holds the marker `<!-- generated: exit-codes -->`. The codes are the `Exit`
enum's and 128 + N for each of `STOP_SIGNALS`; their meanings are the lines of the module's docstring, which lists
every code. The build fails (strict) when a code of the enum has no line there or a line names a code the enum
does not have: the page says what the code does, or there is no page.
"""

from __future__ import annotations

import re
import signal

from rig import exits

MARKER = "<!-- generated: exit-codes -->"
_LINE = re.compile(r"^\s{2,}(\d+|128\+N)\s{2,}(\S.*)$")


class Mismatch(Exception):
    """The docstring of rig.exits and its Exit enum disagree."""


def documented() -> dict[str, str]:
    """code (as written: "0", "70", "128+N") -> its docstring line(s), joined."""
    out: dict[str, str] = {}
    current = None
    for line in (exits.__doc__ or "").splitlines():
        match = _LINE.match(line)
        if match:
            current = match.group(1)
            out[current] = match.group(2).strip()
        elif current is not None and line.startswith(" " * 8) and line.strip():
            out[current] += " " + line.strip()
        else:
            current = None
    return out


def rows() -> list[tuple[str, str, str]]:
    """(code, name, meaning) for every exit code a command can end with."""
    lines = documented()
    enum_codes = {str(int(member)): member.name for member in exits.Exit}
    missing = set(enum_codes) - set(lines)
    extra = set(lines) - set(enum_codes) - {"128+N"}
    if missing or extra or "128+N" not in lines:
        raise Mismatch(f"rig.exits: the docstring's codes {sorted(lines)} and the Exit enum's {sorted(enum_codes)} "
                       f"differ (missing {sorted(missing)}, extra {sorted(extra)})")
    out = [(code, enum_codes[code], lines[code]) for code in sorted(enum_codes, key=int)]
    after = lines["128+N"].split(";", 1)[1].strip() if ";" in lines["128+N"] else ""
    aborted = []
    for name in exits.STOP_SIGNALS:
        if hasattr(signal, name):
            number = int(getattr(signal, name))
            aborted.append((str(exits.aborted(number)), f"128 + {name}",
                            f"aborted by {name} (signal {number})" + (f"; {after}" if after else "")))
    return out + sorted(aborted, key=lambda row: int(row[0]))


def generate() -> str:
    table = ["| code | name | meaning |", "| --- | --- | --- |"]
    table += [f"| {code} | `{name}` | {meaning.replace('|', chr(92) + '|')} |" for code, name, meaning in rows()]
    return "\n".join(table)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, generate())
    return markdown
