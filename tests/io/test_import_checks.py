"""The CSV importer refuses what would be refused only later: time stamps read in the wrong unit (a sample rate
no logger has) and cells beyond the plausible range of the interchange layout, at the line and column the user
wrote; a real log at any rate a sensor can have goes through."""

from __future__ import annotations

import numpy as np
import pytest

from rig.errors import SessionFormatError
from rig.io.import_csv import import_csv

COLUMNS = {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"]}
UNITS = {"accel": "m/s^2", "gyro": "rad/s"}


def _log(path, rate_hz: float, unit_scale: float, n: int = 400, cell: tuple[int, int, str] | None = None):
    rng = np.random.default_rng(3)
    rows = ["t,ax,ay,az,gx,gy,gz,temp"]
    for i in range(n):
        values = [*(rng.normal(0, 0.01, 3) + [0, 0, 9.8]), *rng.normal(0, 0.001, 3), 25.0]
        text = [f"{i / rate_hz * unit_scale:.9g}", *(f"{v:.6f}" for v in values)]
        if cell is not None and cell[0] == i:
            text[cell[1]] = cell[2]
        rows.append(",".join(text))
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("rate_hz, written_in, given", [(100.0, "s", "ms"), (1000.0, "ms", "us"), (200.0, "s", "us")])
def test_time_stamps_in_another_unit_than_given_are_refused_naming_the_right_one(tmp_path, rate_hz, written_in,
                                                                                 given):
    scale = {"s": 1.0, "ms": 1e3, "us": 1e6}[written_in]
    path = _log(tmp_path / "log.csv", rate_hz, scale)
    with pytest.raises(SessionFormatError) as refused:
        import_csv(path, COLUMNS, units=UNITS, time_column="t", time_unit=given)
    text = str(refused.value)
    assert "log.csv" in text and "column 't'" in text and "faster than any inertial sensor" in text
    assert f"give --time-unit {written_in}" in text and f"{rate_hz:g} Hz" in text


@pytest.mark.parametrize("rate_hz, unit", [(100.0, "s"), (1000.0, "ms"), (32000.0, "us")])
def test_real_logs_at_rates_sensors_have_go_through(tmp_path, rate_hz, unit):
    scale = {"s": 1.0, "ms": 1e3, "us": 1e6}[unit]
    session = import_csv(_log(tmp_path / "log.csv", rate_hz, scale), COLUMNS, units=UNITS, time_column="t",
                         time_unit=unit)
    assert session.sample_rate_hz == pytest.approx(rate_hz, rel=1e-3)


@pytest.mark.parametrize("column, cell, unit", [(2, "1e308", "m/s^2"), (5, "-3e5", "rad/s"), (7, "1e308", "degC")])
def test_a_cell_beyond_the_plausible_range_is_refused_at_its_line_and_column(tmp_path, column, cell, unit):
    path = _log(tmp_path / "log.csv", 100.0, 1.0, cell=(57, column, cell))
    with pytest.raises(SessionFormatError) as refused:
        import_csv(path, COLUMNS, units=UNITS, time_column="t", temp_column="temp")
    name = ["t", "ax", "ay", "az", "gx", "gy", "gz", "temp"][column]
    assert f"line 59, column '{name}'" in str(refused.value) and "plausible range" in str(refused.value)
    assert f"{float(cell):g} {unit}" in str(refused.value)
