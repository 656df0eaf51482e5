"""docs/reference/thermal-json.md lists exactly the keys a thermal session writes into `thermal.json`: short
simulated sessions are run and the keys of the manifests they write are compared with the page's key column, both
ways (a key written but not on the page, a key on the page that no session writes)."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import pytest

from docs_paths import DOCS
from procedures.thermal_session import MANIFEST
from rig.commands.thermal_run import builtin_thermal_config, run_thermal_to

PAGE = DOCS / "reference" / "thermal-json.md"
KEY_ROW = re.compile(r"^\| `([^`]+)` \|", re.M)
SENSORS = {"accel", "gyro", "mag"}
PER_SENSOR = {"temperature_model", "causes", "step_plan.predicted"}
OBJECT_LISTS = {"steps", "soaks", "findings", "undistinguished"}   # lists of objects, even when empty
OPAQUE = {"config"}                           # the configuration: the configuration reference's keys
FINDING_LISTS = {"undistinguished[]": "findings[]"}     # documented once, as findings[]
# Written only on a thermal_lag finding: the sessions here carry no lag (tests/procedures/test_thermal_session_lag.py
# runs one that does).
LAG_ONLY = {"causes.<sensor>.findings[].params.tau_s"}


def key_paths(value, path: str = "") -> set[str]:
    """Every key path of a manifest in the page's notation: `a.b`; `a[]` for a list of objects and `a[].b` for its
    elements' keys; `<sensor>` for a per-sensor key (its object a key of its own, empty or not); a list of scalars is a key of its own."""
    if path in OPAQUE:
        return {path}
    if isinstance(value, dict):
        out = {path} if path in PER_SENSOR or (path and not value) else set()
        for key, item in value.items():
            name = "<sensor>" if path in PER_SENSOR and key in SENSORS else key
            out |= key_paths(item, f"{path}.{name}" if path else name)
        return out
    if isinstance(value, list) and (path.rsplit(".", 1)[-1] in OBJECT_LISTS
                                    or (value and all(isinstance(v, dict) for v in value))):
        out = {f"{path}[]"}
        for item in value:
            out |= key_paths(item, f"{path}[]")
        return out
    return {path}


def documented(path: str) -> str:
    for written, page in FINDING_LISTS.items():
        path = path.replace(written + ".", page + ".")
    return path


def page_keys() -> set[str]:
    return set(KEY_ROW.findall(PAGE.read_text(encoding="utf-8")))


def session(tmp_path, name: str, **thermal) -> dict:
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, **thermal)
    config.schedule.rate_hz = 50.0
    config.schedule.mag_every = 1
    out = tmp_path / name
    said: list[str] = []
    code = run_thermal_to(out, config, sim=True, seed=11, progress=False,
                          echo=lambda line="", **_: said.append(str(line)))
    assert code == 0, said
    return json.loads((out / MANIFEST).read_text())


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> set[str]:
    """The key paths of two sessions: two steps on the planner's schedule (step_plan; too few steps for the causes,
    causes_warnings), and one up and down through three set points on a unit with hysteresis (the causes, a finding)."""
    tmp = tmp_path_factory.mktemp("thermal-json")
    planned = session(tmp, "planned", steps_c=[15.0, 35.0], direction="up", orientations=0, hold_s=0.0,
                      step_H_std_pct=0.1, sim_hysteresis=True)
    swept = session(tmp, "swept", steps=3, orientations=9, hold_s=1.5, poll_s=10.0, sim_hysteresis=True)
    return {documented(p) for manifest in (planned, swept) for p in key_paths(manifest)}


def test_every_key_thermal_json_holds_is_on_the_reference_page(written):
    missing = sorted(written - page_keys())
    assert not missing, f"keys thermal.json holds that {PAGE.name} does not list: {missing}"


def test_every_key_on_the_reference_page_is_written_by_a_thermal_session(written):
    listed = page_keys()
    assert LAG_ONLY <= listed
    stale = sorted(listed - written - LAG_ONLY)
    assert not stale, f"keys {PAGE.name} lists that no thermal session writes: {stale}"
