"""Per-test seeded RNG for the vector-calibration tests."""

import zlib

import numpy as np
import pytest


@pytest.fixture
def rng(request) -> np.random.Generator:
    """A different, reproducible seed per test (CRC of the test's name)."""
    return np.random.default_rng(zlib.crc32(request.node.name.encode()))
