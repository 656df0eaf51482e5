"""Checking the arrays (and a hold's table angles) of one hold or move before they are written, and their
summary rows.

A bad array is refused before the transaction starts, with the argument and row named, so a
programming error in the acquisition loop never leaves a half-understood hold in the file.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

QUAT_NORM_TOL = 1e-3

DEFAULT_COLUMNS = {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]}


def sensor_columns(sensor: str, metadata: dict) -> list[str]:
    """Raw column names of a sensor: metadata["sensors"][sensor] if it is a list of three names
    (as in the interchange meta.json), else the spec's names (ax.., gx.., mx..), else `<sensor>_x`.."""
    declared = metadata.get("sensors")
    if isinstance(declared, dict):
        names = declared.get(sensor)
        if isinstance(names, list) and len(names) == 3 and all(isinstance(n, str) for n in names):
            return list(names)
    return DEFAULT_COLUMNS.get(sensor, [f"{sensor}_{axis}" for axis in "xyz"])


def checked_arrays(where: str, t, samples: dict, q_ref, table_deg, temp_c, vsupply_v) -> dict[str, np.ndarray]:
    """Name -> float array for one segment; ValueError naming `where`, the argument and row if bad."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"{where}: t must be a non-empty 1-D array, got shape {t.shape}")
    m = t.size
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{where}: t row {_first(~np.isfinite(t))} is not finite")
    if np.any(np.diff(t) < 0):
        raise ValueError(f"{where}: t decreases at row {_first(np.diff(t) < 0) + 1}")
    out = {"t": t, "q_ref": _shaped(where, "q_ref", q_ref, (m, 4)),
           "table_deg": _shaped(where, "table_deg", table_deg, (m, 2))}
    norm_err = np.abs(np.linalg.norm(out["q_ref"], axis=1) - 1.0)
    if not np.all(norm_err <= QUAT_NORM_TOL):
        raise ValueError(f"{where}: q_ref row {_first(~(norm_err <= QUAT_NORM_TOL))} is not a unit quaternion")
    if not np.all(np.isfinite(out["table_deg"])):
        raise ValueError(f"{where}: table_deg row {_first(~np.isfinite(out['table_deg']).all(1))} is not finite")
    for name, values in (("temp_c", temp_c), ("vsupply_v", vsupply_v)):
        if values is not None:
            out[name] = _shaped(where, name, values, (m,))
    if not samples:
        raise ValueError(f"{where}: samples is empty; a segment needs at least one sensor")
    for sensor, y in samples.items():
        y = _shaped(where, f"samples[{sensor!r}]", y, (m, 3))
        nan = np.isnan(y)
        partial = nan.any(axis=1) & ~nan.all(axis=1)
        if partial.any():
            raise ValueError(f"{where}: samples[{sensor!r}] row {_first(partial)} is NaN on some axes only")
        if np.isinf(y).any():
            raise ValueError(f"{where}: samples[{sensor!r}] row {_first(np.isinf(y).any(1))} is infinite")
        out[f"raw:{sensor}"] = y
    return out


def angle_pair(where: str, name: str, pair: Iterable[float]) -> tuple[float, float]:
    """(outer_deg, inner_deg) of a hold's table angles; ValueError naming `where` and `name` if not two."""
    values = tuple(float(v) for v in pair)
    if len(values) != 2:
        raise ValueError(f"{where}: {name} must be (outer_deg, inner_deg), got {pair!r}")
    return values


def hold_stat_rows(arrays: dict[str, np.ndarray], metadata: dict) -> list[tuple[str, float | None, float | None, int]]:
    """(channel, mean, std, count) per raw column, temperature and supply; NaN cells are not counted."""
    rows = []
    for name, values in arrays.items():
        if name.startswith("raw:"):
            sensor = name[4:]
            rows += [_stat(col, values[:, k]) for k, col in enumerate(sensor_columns(sensor, metadata))]
        elif name in ("temp_c", "vsupply_v"):
            rows.append(_stat(name, values))
    return rows


def _stat(channel: str, values: np.ndarray) -> tuple[str, float | None, float | None, int]:
    present = values[~np.isnan(values)]
    n = int(present.size)
    mean = float(present.mean()) if n else None
    std = float(present.std(ddof=1)) if n > 1 else None
    return channel, mean, std, n


def _shaped(where: str, name: str, values, shape: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.shape != shape:
        raise ValueError(f"{where}: {name} has shape {array.shape}, expected {shape}")
    return array


def _first(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])
