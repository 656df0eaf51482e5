"""The documentation site builds with `mkdocs build --strict` (a broken link, a missing page or a generated page that
cannot be made fails), offline, and its generated pages hold what the code has today."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from docs_paths import ROOT
from rig import config as cfg
from rig import exits
from rig.cli import SUBCOMMANDS
from rig.sim_faults import SimFaults

EXTERNAL = re.compile(r"""<(?:link|script|img|iframe)\b[^>]*\b(?:href|src)=["'](?:https?:)?//""", re.I)
CSS_EXTERNAL = re.compile(r"""@import\s+url\(\s*["']?(?:https?:)?//|url\(\s*["']?https?://""", re.I)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
           "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"mkdocs build --strict failed:\n{done.stdout}\n{done.stderr}"
    return out


def page(site: Path, path: str) -> str:
    return (site / path / "index.html").read_text(encoding="utf-8")


def test_theme_fetches_no_fonts():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    assert config["theme"]["font"] is False
    assert config["strict"] is True


def test_built_pages_load_nothing_from_outside(site):
    offenders = []
    for html in site.rglob("*.html"):
        offenders += [f"{html.relative_to(site)}: {m.group(0)}" for m in EXTERNAL.finditer(html.read_text("utf-8"))]
    for css in site.rglob("*.css"):
        offenders += [f"{css.relative_to(site)}: {m.group(0)}" for m in CSS_EXTERNAL.finditer(css.read_text("utf-8"))]
    assert not offenders, "pages that would fetch from the network:\n" + "\n".join(offenders[:20])


def test_cli_reference_has_every_command(site):
    html = page(site, "reference/cli")
    missing = [name for name in SUBCOMMANDS if f'id="rig-{name}"' not in html]
    assert not missing, f"commands missing from the CLI reference: {missing}"
    assert 'id="rig-import-csv"' in html and "--header-line" in html
    assert "Sentinel" not in html, "an option's default shown as click's internal sentinel"


def test_configuration_reference_has_every_key(site):
    html = page(site, "reference/configuration")
    keys = set()
    for section, names in cfg.SECTIONS.items():
        keys |= set(names or ())
    keys |= {f for f in cfg.TurntableConfig.__dataclass_fields__} | {f for f in cfg.ScheduleConfig.__dataclass_fields__}
    keys |= {f for f in SimFaults.__dataclass_fields__}
    missing = sorted(k for k in keys if f"<code>{k}</code>" not in html)
    assert not missing, f"configuration keys missing from the reference: {missing}"


def test_exit_codes_reference_has_every_code(site):
    html = page(site, "reference/exit-codes")
    for member in exits.Exit:
        assert f"<code>{member.name}</code>" in html
        assert f"<td>{int(member)}</td>" in html
    for code in (129, 130, 143):
        assert f"<td>{code}</td>" in html


def test_measurements_page_has_every_saved_figure(site):
    html = page(site, "measurements")
    for path in sorted((ROOT / "benchmarks" / "results").glob("*.json")):
        for run in json.loads(path.read_text()):
            for name in run["figures"]:
                assert f"<code>{name}</code>" in html, f"{path.name}: figure {name} not on the page"
            assert run["commit"] in html
