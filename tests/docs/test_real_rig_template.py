"""The real-rig configuration template (rig/configs/real-rig.toml) loads with the configuration loader, describes a
rig whose every part and table are real, and names and comments every key the loader reads."""

from __future__ import annotations

import re
from dataclasses import fields

from docs_paths import ROOT
from rig import config as cfg
from rig.assembly import fake_parts, fake_turntable
from rig.board import BUS_KEYS
from rig.config import load_config

TEMPLATE = ROOT / "rig" / "configs" / "real-rig.toml"
KEY_LINE = re.compile(r"^(#\s*)?([A-Za-z_][A-Za-z0-9_]*)\s*=")


def key_lines() -> list[tuple[str, bool, str]]:
    """(key, commented out, the line) for every `key = value` line of the template, commented out or not."""
    out = []
    for line in TEMPLATE.read_text().splitlines():
        match = KEY_LINE.match(line.strip())
        if match:
            out.append((match.group(2), bool(match.group(1)), line))
    return out


def test_template_loads_as_a_real_rig():
    config = load_config(TEMPLATE)
    assert config.source == str(TEMPLATE)
    assert fake_parts(config, simulate=False) == set()
    assert not fake_turntable(config, simulate=False)
    assert config.limits, "a template without limits would make every session's verdict NOT CHECKED"


def test_template_names_every_key_the_loader_reads():
    named = {key for key, _, _ in key_lines()}
    readable = set(BUS_KEYS)
    for section, keys in cfg.SECTIONS.items():
        readable |= set(keys or ()) - {"faults"}
    readable |= {f.name for f in fields(cfg.TurntableConfig)} | {f.name for f in fields(cfg.ScheduleConfig)}
    missing = sorted(readable - named)
    assert not missing, f"{TEMPLATE.name} does not name {missing}"


def test_every_set_key_is_commented():
    bare = [line for key, commented, line in key_lines() if not commented and "#" not in line]
    assert not bare, f"keys without a comment in {TEMPLATE.name}:\n" + "\n".join(bare)
