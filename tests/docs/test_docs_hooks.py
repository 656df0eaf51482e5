"""The generators behind the reference pages refuse to fall behind the code: a key without a meaning, a meaning of a
key the code no longer reads, an exit code the docstring does not list, a results file without its stamp."""

from __future__ import annotations

import json

import pytest

from docs_paths import hook, stamp_module
from rig import exits
from rig.config import load_config


def test_configuration_generator_refuses_a_key_it_cannot_explain(monkeypatch):
    configuration = hook("configuration")
    monkeypatch.delitem(configuration.MEANINGS, ("unit", "serial"))
    with pytest.raises(configuration.Missing, match=r"\[unit\] serial"):
        configuration.generate()


def test_configuration_generator_refuses_a_meaning_of_no_key(monkeypatch):
    configuration = hook("configuration")
    monkeypatch.setitem(configuration.MEANINGS, ("schedule", "no_such_key"), "a key nobody reads")
    with pytest.raises(configuration.Missing, match="no_such_key"):
        configuration.generate()


def test_checked_ranges_are_what_the_loader_enforces(tmp_path):
    configuration = hook("configuration")
    for (section, key), (low, high) in configuration.CHECKED_RANGES.items():
        for value, accepted in ((low - 1, False), (low, True), (high, True), (high + 1, False)):
            path = tmp_path / f"{key}-{value}.toml"
            path.write_text(f"[{section}]\n{key} = {value}\n")
            if accepted:
                load_config(path)
            else:
                with pytest.raises(ValueError, match=key):
                    load_config(path)


def test_exit_code_rows_cover_the_enum_and_the_stop_signals():
    rows = hook("exit_codes").rows()
    codes = [int(code) for code, _, _, _ in rows]
    assert set(codes) == {int(m) for m in exits.Exit} | {129, 130, 143}
    assert all(meaning and status for _, _, meaning, status in rows)


def test_exit_code_generator_refuses_a_code_the_table_lacks(monkeypatch):
    exit_codes = hook("exit_codes")
    monkeypatch.setattr(exits, "EXIT_TABLE", tuple(row for row in exits.EXIT_TABLE if 4 not in row[0]))
    with pytest.raises(exit_codes.Mismatch, match="missing \\[4\\]"):
        exit_codes.rows()


def test_a_saved_result_reaches_the_measurements_page(tmp_path, capsys):
    stamp, measurements = stamp_module(), hook("measurements")
    run = stamp.start("bench_example")
    result = stamp.report(run, {"median_s": 1.25, "target_met": True}, {"runs": [1.2, 1.3]})
    capsys.readouterr()
    stamp.save_result(result, tmp_path)
    stamp.save_result({**result, "figures": {"median_s": 1.5, "target_met": False}}, tmp_path)
    runs = json.loads((tmp_path / "bench_example.json").read_text())
    assert [r["figures"]["median_s"] for r in runs] == [1.25, 1.5]
    assert all(key in runs[0] for key in stamp.REQUIRED) and set(runs[0]["load"]) == {"before", "after"}
    text = measurements.generate(tmp_path)
    assert "## `bench_example`" in text
    assert text.count("| `median_s` |") == 2 and "| 1.5 |" in text and "| 1.25 |" in text


def test_stamp_refuses_figures_that_are_not_flat(capsys):
    stamp = stamp_module()
    with pytest.raises(ValueError, match="nested"):
        stamp.report(stamp.start("bench_example"), {"nested": {"a": 1}})


def test_measurements_refuse_a_run_without_its_stamp(tmp_path):
    measurements = hook("measurements")
    (tmp_path / "bench_example.json").write_text(json.dumps([{"benchmark": "bench_example", "figures": {"x": 1}}]))
    with pytest.raises(measurements.BadResults, match="missing"):
        measurements.generate(tmp_path)


def test_every_saved_result_is_well_formed():
    measurements = hook("measurements")
    files = sorted(measurements.RESULTS.glob("*.json"))
    assert files, "benchmarks/results holds no saved result"
    for path in files:
        measurements.load_runs(path)
