"""The extension point of the effects registry: a new effect is one entry in `rig.effects`,
its simulator-term file and its candidate-test file, and nothing else. A throwaway effect written into the two
packages' search paths is simulated, drawn and found blind by the discrepancy analysis; and no module of the
project outside those three places names an effect."""

from __future__ import annotations

import ast
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import fixtures.world.effects as term_package
import rig.discrepancy.candidates as candidate_package
from fixtures.world import effects_base
from fixtures.world.draw import draw_effect, hidden_effect_cases
from rig.discrepancy import candidates_base, recording_base
from rig.effects import EFFECTS, EffectSpec, discover
from tests.discrepancy.conftest import blind, session_for

ROOT = Path(__file__).resolve().parents[2]
NAME = "accel_bias_curvature"

TERM = '''
"""A throwaway effect of the extension test: the accelerometer's bias bends over the session (a warm-up curve)."""

from dataclasses import dataclass, field

import numpy as np

from fixtures.world.effects_base import TO_PHYS, Effect, axis_vector, simulator_term


@simulator_term(ranges={"accel": (0.004, 0.006)})                  # m/s^2 per min^2
@dataclass
class AccelBiasCurvature(Effect):
    c: np.ndarray = field(default_factory=lambda: np.zeros(3))    # physical unit per s^2, fixture frame
    tc: float = 85.0
    name: str = "accel_bias_curvature"

    def input(self, ctx, u):
        return u + np.multiply.outer((ctx.t - self.tc) ** 2, self.c)

    def magnitude(self):
        return np.abs(self.c).max() * 3600.0 / TO_PHYS[self.sensor]

    @classmethod
    def draw(cls, rng, sensor, m, duration_s):
        return cls(sensor=sensor, c=axis_vector(rng, m) * TO_PHYS[sensor] / 3600.0, tc=duration_s / 2)
'''

CANDIDATE = '''
"""The candidate test of the extension test's throwaway effect: a bias along the squared centred time."""

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, candidate_test, centred, per_axis


@candidate_test("accel_bias_curvature")
def accel_bias_curvature(sensor):
    return Candidate(lambda o, f: per_axis(centred(centred(o.t) ** 2)), AXES,
                     lambda c: float(np.abs(c).max() * 3600.0), lambda c: {"c_per_min2": (c * 3600.0).tolist()})
'''


@pytest.fixture
def new_effect(tmp_path, monkeypatch):
    """The three pieces of a new effect, added the way a contributor adds them; every registry restored after."""
    registries = [effects_base.EFFECTS, effects_base.RANGES, effects_base.DESIGNS, candidates_base.CANDIDATES,
                  recording_base.POSE_REGRESSORS, recording_base.RECORDING_TESTS]
    saved = [dict(r) for r in registries]
    monkeypatch.setitem(EFFECTS, NAME, EffectSpec(NAME, ("accel",), "m/s^2 per min^2", "bias warm-up curve"))
    found = []
    for package, source in ((term_package, TERM), (candidate_package, CANDIDATE)):
        folder = tmp_path / package.__name__.replace(".", "_")
        folder.mkdir()
        (folder / f"{NAME}.py").write_text(textwrap.dedent(source))
        monkeypatch.setattr(package, "__path__", [*package.__path__, str(folder)])
        found.append(discover(package.__name__, package.__path__))
    yield found
    for registry, before in zip(registries, saved):
        registry.clear()
        registry.update(before)
    for package in (term_package, candidate_package):
        sys.modules.pop(f"{package.__name__}.{NAME}", None)


def test_a_new_effect_is_simulated_drawn_and_found_blind_from_its_own_files(new_effect):
    assert all(NAME in names for names in new_effect)
    assert effects_base.EFFECTS[NAME].name == NAME
    assert (NAME, "accel", {}) in hidden_effect_cases()
    drawn = draw_effect(NAME, np.random.default_rng(1), duration_s=170.0)
    assert 0.004 <= drawn.magnitude() <= 0.006 and drawn.unit() == "m/s^2 per min^2"

    session, (effect,) = session_for([(NAME, "accel")], 3)
    report = blind(session)
    assert f"{NAME}:accel" in {f"{c['effect']}:{c['sensor']}" for c in report["candidates"]}
    found = [f for f in report["findings"] if f["effect"] == NAME]
    assert [(f["effect"], f["sensor"]) for f in report["findings"]] == [(NAME, "accel")], report["findings"]
    assert found[0]["unit"] == "m/s^2 per min^2"
    assert found[0]["magnitude"] == pytest.approx(effect.magnitude(), rel=0.25)


# Where an effect's name may stand as a string: the registry, each effect's own files, and the places that choose
# effects by name on purpose (tests hide named effects; benchmarks pick the pairs they measure).
OWN_FILES = ("rig/effects.py", "fixtures/world/effects/", "rig/discrepancy/candidates/")
CHOOSERS = ("tests/", "benchmarks/")


def test_no_module_outside_the_registry_and_the_effects_own_files_names_an_effect():
    names = set(EFFECTS)
    found = []
    for package in ("drivers", "rig", "fixtures", "procedures", "scripts"):
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel.startswith(OWN_FILES + CHOOSERS):
                continue
            for node in ast.walk(ast.parse(path.read_text(), rel)):
                if isinstance(node, ast.Constant) and node.value in names:
                    found.append(f"{rel}:{node.lineno}: {node.value!r}")
    assert not found, "effect names outside the registry:\n" + "\n".join(found)


def test_the_name_scan_sees_a_name():
    tree = ast.parse('x = {"bias_drift": 1}')
    assert [n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and n.value in EFFECTS] == ["bias_drift"]
