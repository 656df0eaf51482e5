"""The examples of the guide for other teams' CI (docs/guides/fakes-in-ci.md) run as that team would run them: its
Python blocks as one test file, pytest with the rig plugin and nothing of rig's own test code."""

from __future__ import annotations

import os
import re
import subprocess
import sys

from docs_paths import DOCS, ROOT

GUIDE = DOCS / "guides" / "fakes-in-ci.md"


def test_fakes_in_ci_examples_pass(tmp_path):
    blocks = re.findall(r"^```python\n(.*?)^```", GUIDE.read_text(), re.S | re.M)
    assert len(blocks) >= 3
    (tmp_path / "test_team.py").write_text("\n\n".join(blocks))
    env = {**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    env.pop("PYTEST_ADDOPTS", None)
    command = [sys.executable, "-m", "pytest", "-q", "-p", "fixtures.pytest_plugin", "-p", "no:cacheprovider",
               "test_team.py"]
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(r"\b3 passed\b", done.stdout), done.stdout
