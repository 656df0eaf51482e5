"""numpy arrays as SQLite BLOBs: little-endian bytes plus dtype and shape.

One BLOB per array per hold or move (not one SQL row per sample) keeps a 500-row hold to a dozen
INSERTs, so a commit costs one fsync and not thousands of statements, and loading a session is a
handful of `np.frombuffer` calls.
"""

from __future__ import annotations

import json

import numpy as np

STORED_DTYPES = {"f8": np.dtype("<f8"), "i4": np.dtype("<i4")}


def encode(array: np.ndarray, dtype: str = "f8") -> tuple[str, str, bytes]:
    """(dtype code, JSON shape, bytes) of `array` converted to the stored dtype."""
    stored = np.ascontiguousarray(array, dtype=STORED_DTYPES[dtype])
    return dtype, json.dumps(list(stored.shape)), stored.tobytes()


def decode(dtype: str, shape: str, blob: bytes) -> np.ndarray:
    """Inverse of `encode`; raises ValueError when the bytes do not fill the recorded shape."""
    if dtype not in STORED_DTYPES:
        raise ValueError(f"unknown stored dtype {dtype!r}")
    dims = tuple(json.loads(shape))
    array = np.frombuffer(blob, dtype=STORED_DTYPES[dtype])
    if array.size != int(np.prod(dims)):
        raise ValueError(f"BLOB holds {array.size} values, shape {list(dims)} needs {int(np.prod(dims))}")
    return array.reshape(dims)
