"""The twin writes its replicas as the recording was written: the form is read from the recording's values (its
print resolution, its storage's), never a rounding of the twin's own."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from hand_motions import hand_recording, hand_session  # noqa: E402

from procedures.twin.analysis import analyse_twin  # noqa: E402
from procedures.twin.printed import Printed, printed_form  # noqa: E402


def printed(x: np.ndarray, form: str) -> np.ndarray:
    """x as a logger writes it and a reader reads it back: through the text, not through our own rounding."""
    return np.array([float(format(v, form)) for v in x.ravel()]).reshape(x.shape)


@pytest.fixture(scope="module")
def values() -> np.ndarray:
    rng = np.random.default_rng(3)
    return np.concatenate([rng.normal(9.81, 0.01, 3000), rng.normal(-0.3, 0.01, 3000), rng.normal(4.2, 0.01, 3000)])


def test_the_form_of_a_stream_is_read_from_its_values(values):
    assert printed_form(printed(values, ".5f")) == Printed("decimals", 5)
    assert printed_form(printed(values, ".6g")) == Printed("digits", 6)
    assert printed_form(printed(values, ".7g")) == Printed("digits", 7)
    assert printed_form(values.astype(np.float32).astype(float)) == Printed("float32")
    assert printed_form(printed(values.astype(np.float32), ".9g")) == Printed("float32")
    assert printed_form(values) is None
    q = 9.81 / 2048                                     # counts times a scale, in full: a quantum, no print
    assert printed_form(np.round(values / q) * q) is None


@pytest.mark.parametrize("form", [".5f", ".6g", "float32"])
def test_a_printed_form_applied_writes_the_values_as_the_print_does(values, form):
    """The replica's values land where the print's would (to a part in 1e12 of a value: the parse's last bit)."""
    expected = values.astype(np.float32).astype(float) if form == "float32" else printed(values, form)
    y = values.copy()
    printed_form(expected).apply(y)
    assert np.all(np.abs(y - expected) <= 1e-12 * np.abs(expected)), np.abs(y - expected).max()


@pytest.mark.parametrize("form,rest_s", [(".6g", 20.0), ("float32", 150.0)])
def test_an_accelerometer_written_in_significant_digits_or_single_precision_keeps_its_steps_inside(form, rest_s):
    """A hand recording (SI units, 100 Hz, white noise only) whose accelerometer was written with C's `%.6g` (1e-5
    m/s^2 at 9.8) or kept as float32 (4.8e-7 and 9.5e-7 m/s^2 between 4 and 16; a rest of 150 s lies so densely that
    its values fall on that grid): its value steps are the replicas' too, so they are inside before any extension
    and nothing is named. The twin had rounded a `%.6g` stream to the 8 decimals its smallest values carry and
    left a float32 stream in full precision, whose values interleave more densely than float32's grid."""
    session = hand_session(hand_recording(7, rest_s=rest_s), rest_s=rest_s)
    y = session.raw["accel"]
    session.raw["accel"] = y.astype(np.float32).astype(float) if form == "float32" else printed(y, form)
    report = analyse_twin(session, replicas=30, attribution_replicas=6)
    steps = [n for n in report["summary"]["outside_before"] if n.startswith("accel.step")]
    assert steps == [], [(n, report["statistics"][n]["real"], report["statistics"][n]["before"]) for n in steps]
    assert report["causes"] == [], [(c["effect"], c["sensor"]) for c in report["causes"]]
