"""The [chamber] section of a rig configuration: keys, ranges, the profile read where the file is read."""

from __future__ import annotations

import shutil
from importlib import resources

import pytest

from rig.config import config_from_dict, load_config


def write(tmp_path, text: str):
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_a_chamber_section_is_read_with_its_profile_beside_the_file(tmp_path):
    source = resources.files("rig.chamber") / "profiles" / "watlow-f4t.toml"
    shutil.copyfile(str(source), tmp_path / "my-f4t.toml")
    cfg = load_config(write(tmp_path, '[chamber]\nurl = "tcp://10.0.0.7:502"\nprofile = "my-f4t.toml"\n'
                                      "tolerance_c = 0.3\nsoak_timeout_s = 5400\n"))
    assert cfg.chamber.url == "tcp://10.0.0.7:502"
    assert cfg.chamber.profile == str(tmp_path / "my-f4t.toml")
    assert (cfg.chamber.tolerance_c, cfg.chamber.soak_timeout_s) == (0.3, 5400)
    again = config_from_dict(cfg.to_dict())
    assert again.chamber == cfg.chamber


def test_no_chamber_section_means_no_chamber(tmp_path):
    cfg = load_config(write(tmp_path, '[unit]\nserial = "X1"\n'))
    assert cfg.chamber is None
    assert config_from_dict(cfg.to_dict()).chamber is None


@pytest.mark.parametrize("text, message", [
    ("[chamber]\ntolerance = 0.3\n", r"\[chamber\] has unknown keys \['tolerance'\]"),
    ("[chamber]\ntolerance_c = 0\n", r"\[chamber\] tolerance_c = 0 must be in 0.01..20"),
    ("[chamber]\nurl = 502\n", r"\[chamber\] url = 502 must be a string"),
    ('[chamber]\nprofile = "missing.toml"\n', r"\[chamber\] profile = 'missing.toml'.*no such file"),
])
def test_bad_chamber_keys_are_named(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        load_config(write(tmp_path, text))
