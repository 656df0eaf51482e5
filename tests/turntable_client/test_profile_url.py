"""The default profile encodes tt-map/1; bad profiles and URLs fail naming the file/key or URL part."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rig.turntable.errors import ProfileError
from rig.turntable.profile import decode_bits, default_profile_path, load_profile
from rig.turntable.status import int_to_words, words_to_int
from rig.turntable.url import parse_url
from tests.paths import DOCS

SPEC = DOCS / "reference" / "turntable-map.md"


def spec_rows() -> dict[str, int]:
    """name -> address / offset, parsed from the spec's markdown tables."""
    rows = {}
    for m in re.finditer(r"^\| (0x[0-9A-F]{4}|\+0x[0-9A-F]{2}) \| (\w+) \|", SPEC.read_text(), re.M):
        rows[m.group(2)] = int(m.group(1).lstrip("+"), 16)
    return rows


def test_default_profile_matches_the_spec_tables():
    p = load_profile()
    rows = spec_rows()
    assert {n: rows[n] for n in p.global_regs} == p.global_regs
    assert {n: rows[n] for n in p.axis_regs} == p.axis_regs
    assert len(rows) == len(p.global_regs) + len(p.axis_regs)


def test_default_profile_meanings():
    p = load_profile()
    assert p.axis_bases == (0x0100, 0x0200) and p.axis_names == ("outer", "inner")
    assert (p.expected_device_id, p.expected_map_version, p.device_id, p.word_order) == (0x5454, 0x0100, 1, "big")
    assert p.feedback_block() == (0x10, 12)
    assert p.commands["MOVE_ABS"] == 1 and p.commands["STOP"] == 4 and p.commands["ALARM_RESET"] == 0x10
    assert decode_bits(0b10_0000_0101, p.status_bits) == {"ENABLED", "IN_POSITION", "CMD_REJECTED"}
    assert decode_bits(1 << 14, p.status_bits) == {"BIT14"}
    assert p.alarm_name(5) == "COMMS_WATCHDOG" and p.last_error_name(2) == "OUT_OF_LIMITS"
    assert p.alarm_name(77) == "UNKNOWN_ALARM_77"


def test_word_order_big_and_little(tmp_path):
    big = load_profile()
    little = load_profile(_edit(tmp_path, 'word_order = "big"', 'word_order = "little"'))
    assert int_to_words(big, -123456, "TARGET_POS") == [0xFFFE, 0x1DC0]
    assert int_to_words(little, -123456, "TARGET_POS") == [0x1DC0, 0xFFFE]
    assert words_to_int(little, [0x1DC0, 0xFFFE], "ACTUAL_POS") == -123456
    assert words_to_int(big, [0x0001, 0x0000], "ACCEL") == 65536
    with pytest.raises(ValueError, match="ACCEL=-1 out of range"):
        int_to_words(big, -1, "ACCEL")


def _edit(tmp_path: Path, old: str, new: str) -> Path:
    text = default_profile_path().read_text()
    assert old in text
    path = tmp_path / "table.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old,new,key", [
    ('word_order = "big"', 'word_order = "middle"', "word_order"),
    ("STATUS = 0x18", "STATUS = 0x17", "axis_registers.STATUS"),          # overlaps FOLLOWING_ERR's 2nd word
    ("CMD_SEQ = 0x1B", "", "axis_registers.CMD_SEQ"),                      # missing
    ("MOVING = 1", "MOVING = 0", "status_bits.MOVING"),                     # duplicate bit
    ("MOVING = 1", "MOVING = 16", "status_bits.MOVING"),                    # not a bit of a u16
    ('bases = [0x0100, 0x0200]', 'bases = [0x0100]', "axes.bases"),
    ("device_id = 1 ", "device_id = 300 ", "device_id"),
    ("units_per_degree = 1000", "units_per_degree = 0", "units_per_degree"),
    ("CMD_SEQ = 0x1B", "CMD_SEQ = 0x9B", "axis_registers"),               # feedback no longer one FC03
])
def test_bad_profile_names_file_and_key(tmp_path, old, new, key):
    path = _edit(tmp_path, old, new)
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    assert err.value.key == key
    assert str(path) in str(err.value) and f"'{key}'" in str(err.value)


def test_unreadable_profiles(tmp_path):
    with pytest.raises(ProfileError, match="no such file"):
        load_profile(tmp_path / "missing.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("name = \n")
    with pytest.raises(ProfileError, match="broken.toml.*not valid TOML"):
        load_profile(broken)


def test_urls():
    assert parse_url("tcp://10.0.0.5:1502") == parse_url("tcp://10.0.0.5:1502/")
    tcp = parse_url("tcp://10.0.0.5:1502")
    assert (tcp.scheme, tcp.host, tcp.port, tcp.is_serial_client) == ("tcp", "10.0.0.5", 1502, False)
    assert parse_url("tcp://table.lab").port == 502
    rtu = parse_url("rtu:///dev/ttyUSB0?baud=19200&parity=e&stopbits=2&bytesize=7")
    assert (rtu.device, rtu.baud, rtu.parity, rtu.stopbits, rtu.bytesize) == ("/dev/ttyUSB0", 19200, "E", 2, 7)
    default = parse_url("rtu:///dev/ttyS1")
    assert (default.baud, default.parity, default.stopbits, default.bytesize) == (115200, "N", 1, 8)
    sock = parse_url("rtu+socket://127.0.0.1:5020")
    assert (sock.scheme, sock.host, sock.port, sock.is_serial_client) == ("rtu+socket", "127.0.0.1", 5020, False)


@pytest.mark.parametrize("url,part", [
    ("127.0.0.1:502", "missing scheme"),
    ("udp://127.0.0.1:502", "scheme 'udp'"),
    ("tcp://:502", "missing host"),
    ("tcp://host:99999", "port"),
    ("tcp://host:502/x", "unexpected path"),
    ("rtu+socket://host", "missing port"),
    ("rtu://host/dev/ttyUSB0", "host part 'host'"),
    ("rtu:///dev/ttyUSB0?baud=fast", "baud='fast'"),
    ("rtu:///dev/ttyUSB0?parity=X", "parity='X'"),
    ("rtu:///dev/ttyUSB0?stopbits=3", "stopbits=3"),
    ("rtu:///dev/ttyUSB0?speed=9600", "unknown query parameter 'speed'"),
])
def test_bad_urls_name_the_part(url, part):
    with pytest.raises(ValueError) as err:
        parse_url(url)
    assert part in str(err.value)
