"""imucal's Ferraris sessions (six faces and a 360 deg turn about each axis, by hand) as recordings.

Two layouts (imucal, `example_data/`): a continuous CSV (`n_samples, gyr_x.., acc_x..`) with a JSON section list
`{name: {start, end}}` of row positions (end exclusive, as imucal's `data.iloc[start:end]`), or one CSV of the
sections already cut (`part, samples, acc_x.., gyr_x..`). A face `x_p` is static with the sensor's +x up (`x_a`:
-x up); a turn `x_rot` is a rotation about +x. What the hand gives is known only roughly, and the session says
how roughly: `tilt_deg_sd` for a face (a table not level, a box not square to its content), `angle_deg_sd` for a
turn (four quarter turns against a box edge). The sense of a turn is what the protocol leaves open (imucal's two
examples turn opposite ways): it is taken from the data, the sign of the gyro's integral over the turn after
the bias of the faces is removed, unless the user gives it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from rig.errors import InputError, SessionFormatError
from rig.io.columns import FIRST_DATA_LINE, read_columns, read_header
from rig.io.text_file import read_utf8
from rig.io.recording import STANDARD_GRAVITY, check_counts, recording_session, to_session_units
from rig.session_data import SessionData

FACES = {"x_p": "+x", "x_a": "-x", "y_p": "+y", "y_a": "-y", "z_p": "+z", "z_a": "-z"}
TURNS = {"x_rot": "+x", "y_rot": "+y", "z_rot": "+z"}
COLUMNS = {"accel": ["acc_x", "acc_y", "acc_z"], "gyro": ["gyr_x", "gyr_y", "gyr_z"]}
TILT_SD_DEG = 2.0       # a face put down by hand: table tilt and a box not square to the unit
TURN_SD_DEG = 2.0       # a full turn in four quarter turns against a box edge, by hand
TURN_DEG = 360.0
PART_GAP_S = 1.0        # between the pieces of a pre-cut file: the motion between them was not recorded


def import_ferraris(*, rate_hz: float, units: dict[str, str], csv: str | os.PathLike | None = None,
                    sections: str | os.PathLike | None = None, annotated: str | os.PathLike | None = None,
                    turn_deg: float | None = None, tilt_sd_deg: float = TILT_SD_DEG,
                    turn_sd_deg: float = TURN_SD_DEG, gravity: float = STANDARD_GRAVITY) -> SessionData:
    """One Ferraris session: `csv` + `sections`, or `annotated`. `turn_deg` (signed, right-hand rule about the
    turn's axis) for every turn; None takes each turn's sense from the data."""
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"--rate-hz {rate_hz!r}: must be a positive number")
    if annotated is not None and (csv is not None or sections is not None):
        raise InputError("give --csv with --sections, or --annotated, not both")
    if annotated is None and (csv is None or sections is None):
        raise InputError("a continuous Ferraris recording needs both --csv and --sections (or give --annotated)")
    if turn_deg is not None and not (np.isfinite(turn_deg) and turn_deg != 0):
        raise InputError(f"--turn-deg {turn_deg!r}: a signed, non-zero angle (e.g. 360 or -360)")
    for name, value in (("--tilt-sd-deg", tilt_sd_deg), ("--turn-sd-deg", turn_sd_deg)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} {value!r}: must be a positive number of degrees")
    if annotated is not None:
        path = Path(annotated)
        index, raw, spans = _annotated(path)
        t = _pieces_apart(index / float(rate_hz), spans)
    else:
        path = Path(csv)
        index, raw = _continuous(path)
        spans = _sections(Path(sections), len(index))
        t = index / float(rate_hz)
    lines = np.arange(len(index)) + FIRST_DATA_LINE
    check_counts(raw, units, {s: (str(path), names, lines) for s, names in COLUMNS.items()})
    raw, kept = to_session_units(raw, units)
    segments = _segments(t, raw["gyro"], spans, turn_deg, tilt_sd_deg, turn_sd_deg)
    return recording_session(t, raw, units=kept, gravity=gravity, sample_rate_hz=float(rate_hz), source=str(path),
                             segments=segments,
                             imported={"format": "imucal-ferraris", "files": [str(p) for p in (csv, sections, annotated)
                                                                              if p is not None],
                                       "units": units, "turn_sense": "from the data" if turn_deg is None else "given",
                                       **({"pieces": f"each part is a separate piece; {PART_GAP_S:g} s left between "
                                                     "them (the motions between them were not recorded)"}
                                          if annotated is not None else {})})


def _continuous(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    header = read_header(path)
    _require(path, header, ["n_samples", *COLUMNS["accel"], *COLUMNS["gyro"]])
    cols = read_columns(path, header, ["n_samples", *COLUMNS["accel"], *COLUMNS["gyro"]],
                        integers=("n_samples",), required=tuple(header))
    index = cols["n_samples"]
    back = np.flatnonzero(np.diff(index) <= 0)
    if back.size:
        raise SessionFormatError(path, "n_samples must increase from row to row", int(back[0]) + 1 + FIRST_DATA_LINE,
                                 "n_samples")
    return index, {s: np.column_stack([cols[c] for c in names]) for s, names in COLUMNS.items()}


def _annotated(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, tuple[int, int]]]:
    """Rows sorted by their sample index; each part one contiguous run of rows."""
    header = read_header(path)
    _require(path, header, ["part", "samples", *COLUMNS["accel"], *COLUMNS["gyro"]])
    numeric = ["samples", *COLUMNS["accel"], *COLUMNS["gyro"]]
    cols = read_columns(path, header, numeric, ["part"], integers=("samples",), required=tuple(numeric))
    order = np.argsort(cols["samples"], kind="stable")
    index, part = cols["samples"][order], cols["part"][order]
    twice = np.flatnonzero(np.diff(index) == 0)
    if twice.size:
        raise SessionFormatError(path, f"sample {int(index[twice[0]])} appears on two rows",
                                 int(order[twice[0] + 1]) + FIRST_DATA_LINE, "samples")
    spans: dict[str, tuple[int, int]] = {}
    starts = np.flatnonzero(np.r_[True, part[1:] != part[:-1]])
    for a, b in zip(starts, np.r_[starts[1:], len(part)]):
        name = str(part[a])
        if name not in FACES and name not in TURNS:
            raise SessionFormatError(path, f"part {name!r} is not a Ferraris section ({', '.join([*FACES, *TURNS])})",
                                     int(order[a]) + FIRST_DATA_LINE, "part")
        if name in spans:
            raise SessionFormatError(path, f"part {name!r} is split by other parts (its samples are not one run)",
                                     int(order[a]) + FIRST_DATA_LINE, "part")
        spans[name] = (int(a), int(b))
    return index, {s: np.column_stack([cols[c][order] for c in names]) for s, names in COLUMNS.items()}, spans


def _pieces_apart(t: np.ndarray, spans: dict[str, tuple[int, int]]) -> np.ndarray:
    """A pre-cut file numbers its samples on across the cuts (imucal's x_p ends at 1027 and x_a starts at 1028,
    with no motion between): time restarts after a gap at every piece, so nothing reads the cut as a motion."""
    out = t.copy()
    for k, (a, _) in enumerate(sorted(spans.values())):
        if k:
            out[a:] += PART_GAP_S
    return out


def _sections(path: Path, rows: int) -> dict[str, tuple[int, int]]:
    """imucal's section list: {name: {"start": i, "end": j}}, row positions, end exclusive."""
    text = read_utf8(path, lambda message, line: SessionFormatError(path, message, line))
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise SessionFormatError(path, f"not valid JSON: {e.msg}", e.lineno) from None
    if not isinstance(doc, dict) or not doc:
        raise SessionFormatError(path, 'must be an object {"x_p": {"start": i, "end": j}, ...}')
    spans = {}
    for name, span in doc.items():
        if name not in FACES and name not in TURNS:
            raise SessionFormatError(path, f"section {name!r} is not a Ferraris section ({', '.join([*FACES, *TURNS])})",
                                     column=name)
        start, end = (span.get("start"), span.get("end")) if isinstance(span, dict) else (None, None)
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in (start, end)) or not 0 <= start < end <= rows:
            raise SessionFormatError(path, f"section {name!r} must have integer start < end within the {rows} rows of "
                                     f"the recording, got {span!r}", column=name)
        spans[name] = (start, end)
    return spans


def _segments(t: np.ndarray, gyro: np.ndarray, spans: dict[str, tuple[int, int]], turn_deg: float | None,
              tilt_sd_deg: float, turn_sd_deg: float) -> list[dict]:
    faces = [name for name in spans if name in FACES]
    bias = (np.concatenate([gyro[slice(*spans[f])] for f in faces]).mean(axis=0) if faces
            else np.zeros(3))
    segments = []
    for name, (a, b) in spans.items():
        seg = {"name": name, "t0": float(t[a]), "t1": float(t[b - 1])}
        if name in FACES:
            seg.update(kind="static", up=FACES[name], tilt_deg_sd=float(tilt_sd_deg))
        else:
            axis = "xyz".index(TURNS[name][1])
            if turn_deg is None:
                turned = float(np.sum((gyro[a:b, axis] - bias[axis])[:-1] * np.diff(t[a:b])))
                angle = TURN_DEG if turned >= 0 else -TURN_DEG
            else:
                angle = float(turn_deg)
            seg.update(kind="rotation", axis=TURNS[name], angle_deg=angle, angle_deg_sd=float(turn_sd_deg))
        segments.append(seg)
    return sorted(segments, key=lambda s: s["t0"])


def _require(path: Path, header: list[str], names: list[str]) -> None:
    for name in names:
        if name not in header:
            raise SessionFormatError(path, f"column {name!r} of imucal's layout is missing; the header has "
                                     f"{', '.join(header)}", 1, name)
