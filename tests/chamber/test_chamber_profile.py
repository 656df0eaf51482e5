"""Chamber profiles: another map (loop 2 of an F4T, high word first) drives client and fake alike; a broken
profile is refused naming the file and the key."""

from __future__ import annotations

import re
from importlib import resources

import pytest

from fixtures.chamber import ChamberServer, FakeChamber
from rig.chamber import ChamberLink, ProfileError, load_profile
from rig.clock import SimClock

DEFAULT = (resources.files("rig.chamber") / "profiles" / "watlow-f4t.toml").read_text()


def loop_two_big_endian(text: str) -> str:
    """Loop 2 sits 160 registers above loop 1 (chamber-map.md); the process value moves to loop 2's too."""
    for name, address in (("SET_POINT", 2782), ("WORKING_SET_POINT", 2810), ("RAMP_RATE", 2798),
                          ("RAMP_ACTION", 2794), ("RAMP_SCALE", 2796)):
        text = re.sub(rf"^{name} = {address}", f"{name} = {address + 160}", text, flags=re.M)
    text = re.sub(r"^PROCESS_VALUE = 27586", "PROCESS_VALUE = 2980", text, flags=re.M)
    return text.replace('word_order = "little"', 'word_order = "big"')


def test_another_map_is_served_and_driven_by_its_profile(tmp_path):
    path = tmp_path / "loop2.toml"
    path.write_text(loop_two_big_endian(DEFAULT))
    profile = load_profile(path)
    assert (profile.floats["SET_POINT"], profile.word_order) == (2942, "big")
    clock = SimClock()
    chamber = FakeChamber(clock, profile)
    with ChamberServer(chamber) as server, ChamberLink(server.url, profile=path, clock=clock) as link:
        link.ramp_rate(5.0)
        link.set_point(35.5)
        link.run()
        assert chamber.state.set_point == pytest.approx(35.5)
        assert link.wait_air(35.5, 0.2, timeout=1800.0) == pytest.approx(35.5, abs=0.2)
    with ChamberServer(FakeChamber(clock)) as server:
        with pytest.raises(Exception, match="ILLEGAL_DATA_ADDRESS"):     # the loop-1 fake has no loop 2
            ChamberLink(server.url, profile=path, clock=clock, retries=0).connect().set_point(30.0)


@pytest.mark.parametrize("edit, key", [
    (lambda t: t.replace('word_order = "little"', 'word_order = "middle"'), "word_order"),
    (lambda t: t.replace("SET_POINT = 2782", "SET_POINT = 2797"), "RAMP_RATE|SET_POINT"),   # overlap
    (lambda t: t.replace("ON = 63\n", ""), "values.RUN.ON"),
    (lambda t: t.replace("PROCESS_VALUE = 27586", "PROCESS_VALU = 27586"), "floats.PROCESS_VALU"),
    (lambda t: t.replace("max_c = 180.0", "max_c = -80.0"), "limits"),
])
def test_a_broken_profile_is_refused_naming_file_and_key(tmp_path, edit, key):
    path = tmp_path / "broken.toml"
    path.write_text(edit(DEFAULT))
    with pytest.raises(ProfileError, match=rf"chamber profile .*broken.toml: key '({key})'"):
        load_profile(path)
