"""MkDocs hook: the command-line reference's tables say "no default" where click has none.

mkdocs-click writes each option's default as `repr`; click 8.3 marks an option given no default with its UNSET
sentinel, which the table showed as `Sentinel.UNSET`. This hook writes a dash there, on the rendered page of the
command line only.
"""

from __future__ import annotations

import re

PAGE = "reference/cli.md"
UNSET = re.compile(r"<code>Sentinel\.UNSET</code>")


def on_page_content(html: str, page, config, files) -> str:
    if page.file.src_uri == PAGE:
        return UNSET.sub("-", html)
    return html
