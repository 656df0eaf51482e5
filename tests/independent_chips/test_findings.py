"""The independent emulators' findings against the drivers stay fixed (see FINDINGS.md)."""

import pytest

from findings import FINDINGS


@pytest.mark.parametrize("finding", FINDINGS, ids=lambda f: f.__name__)
def test_finding_stays_fixed(finding):
    got, expected = finding()
    assert [int(v) for v in got] == expected, finding.__doc__
