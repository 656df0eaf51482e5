"""`rig noise`'s analysis of a still recording: the stretch it reads, the warm-up at that stretch's start, and the
noise terms each axis determines (`rig.noise.terms`), in the units the recording holds.

The stretch is the whole recording, the part between `start_s` and `end_s` (seconds from the recording's start),
or its longest still stretch (`window="still"`, `rig.noise.window`). A stretch that moves is refused with where it
moves. Each axis's start is searched for a warm-up (`rig.noise.warm_up`); by default a sensor is analysed from
where its slowest axis has settled, since a user asks for the noise of the unit as it runs, and a warm-up read as
noise is reported as bias instability and rate random walk it is not. `skip_warm_up=False` analyses the stretch
whole, the warm-up still named.
"""

from __future__ import annotations

import numpy as np

from rig.errors import InputError
from rig.noise.allan import allan_deviation
from rig.noise.still import STILL_RATIO, stillness_ratio
from rig.noise.terms import FITTED, TERM_KEYS, determine_terms
from rig.noise.warm_up import find_warm_up
from rig.noise.window import longest_still, motion
from rig.session_data import SessionData

SCHEMA = "rig-noise/1"
WINDOWS = ("record", "still")
MIN_SAMPLES = 8               # the least an Allan deviation is taken of (`rig.noise.allan`)


def _rate(session: SessionData) -> float:
    return float(session.sample_rate_hz or 1.0 / np.median(np.diff(session.t)))


def _spans(spans: list[tuple[float, float]]) -> str:
    shown = ", ".join(f"{a:.1f}-{b:.1f}" for a, b in spans[:4])
    return shown + (f" and {len(spans) - 4} more" if len(spans) > 4 else "")


def stretch(session: SessionData, rate: float, start_s: float | None, end_s: float | None,
            window: str) -> tuple[int, int, str]:
    """(first row, past the last row, what it is) of the stretch analysed; InputError names the option at fault."""
    if window not in WINDOWS:
        raise InputError(f"--window {window!r}: one of {', '.join(WINDOWS)}")
    since = session.t - session.t[0]
    length = float(since[-1])
    start = 0.0 if start_s is None else float(start_s)
    end = length if end_s is None else float(end_s)
    if not 0 <= start < length:
        raise InputError(f"--start {start:g} s: the recording runs from 0 to {length:g} s")
    if end_s is not None and not start < end <= length:
        raise InputError(f"--end {end:g} s: it must be after the start ({start:g} s) and within the recording's "
                         f"{length:g} s")
    first, last = int(np.searchsorted(since, start)), int(np.searchsorted(since, end, side="right"))
    if last - first < MIN_SAMPLES:
        raise InputError(f"--start/--end: {last - first} samples from {start:g} to {end:g} s; an Allan deviation "
                         f"needs at least {MIN_SAMPLES}")
    how = "the whole recording" if start_s is None and end_s is None else "the part given by --start/--end"
    streams = {name: y[first:last] for name, y in session.raw.items()}
    if window == "still":
        found = longest_still(streams, rate)
        if found is None:
            raise InputError(f"{session.source}: no still stretch between {start:g} and {end:g} s: it moves in "
                             "every second")
        return first + found[0], first + found[1], f"the longest still stretch of {how}"
    moved = motion(streams, rate)
    if moved.where is not None:
        sensor, axis = moved.where
        raise InputError(f"{session.source}: {sensor}.{axis} is not still: it moves at "
                         f"{_spans([(a + start, b + start) for a, b in moved.spans(since[first:last] - start)])} s; "
                         "`rig noise` reads a still recording (one pose held), and the Allan deviation of a moving "
                         "one says nothing about its noise: give --window still to analyse its longest still "
                         "stretch, or --start/--end")
    return first, last, how


def _axis(session: SessionData, sensor: str, axis: str, stream: np.ndarray, rate: float,
          trend: np.ndarray) -> dict:
    """The terms of one axis's analysed stream; `trend` (the warm-up found, zero without one) is taken out of the
    stream only to judge whether the rest of it is still."""
    try:
        curve = allan_deviation(stream, rate)
    except ValueError as exc:
        raise InputError(f"{session.source}: {sensor}.{axis}: {exc}") from None
    ratio = stillness_ratio(stream - trend)
    if ratio > STILL_RATIO:
        raise InputError(f"{session.source}: {sensor}.{axis} is not still: its spread is {ratio:.0f} times its "
                         "sample-to-sample noise; `rig noise` reads a still recording (one pose held), and the Allan "
                         "deviation of a drifting one says nothing about its noise: give --start/--end or --window "
                         "still to analyse a still part of it")
    finite = int(np.isfinite(stream).sum())
    fit = determine_terms(curve, finite / rate)
    out = {"tau_s": curve.tau.tolist(), "adev": curve.adev.tolist(), "adev_err": curve.err.tolist(),
           "samples": finite, "record_s": fit.record_s}
    for key in TERM_KEYS:
        term = fit.terms[key]
        out[key] = term.value if term.status == FITTED else None
        out[f"{key}_std"] = term.std if term.status == FITTED else None
    out["terms"] = {key: fit.terms[key].to_dict() for key in TERM_KEYS}
    return out


def analyse_still(session: SessionData, *, start_s: float | None = None, end_s: float | None = None,
                  window: str = "record", skip_warm_up: bool = True) -> dict:
    """Per sensor and axis: the warm-up at the stretch's start (`start_trend`, or None), the overlapping Allan
    deviation of what is analysed (octave taus up to a third of it) and its terms, each fitted, not determinable
    or absent; where each sensor's analysis starts and ends (`spans`, seconds from the recording's start)."""
    if len(session.t) < MIN_SAMPLES:
        raise InputError(f"{session.source}: {len(session.t)} samples; an Allan deviation needs at least {MIN_SAMPLES}")
    rate = _rate(session)
    first, last, how = stretch(session, rate, start_s, end_s, window)
    since = session.t - session.t[0]
    units = session.meta.get("units", {})
    out = {"schema": SCHEMA, "session": str(session.source), "rate_hz": rate, "rows": int(len(session.t)),
           "seconds": float(since[-1]), "units": {s: units.get(s, "counts") for s in session.raw},
           "analysed": {"window": window, "what": how, "start_s": float(since[first]),
                        "end_s": float(since[last - 1]), "skip_warm_up": bool(skip_warm_up)},
           "spans": {}, "sensors": {}}
    t = since[first:last] - since[first]
    for sensor, y in session.raw.items():
        part = y[first:last]
        trends = {axis: find_warm_up(t, part[:, k]) for k, axis in enumerate("xyz")}
        settled = max((w.settled_s for w in trends.values() if w is not None), default=0.0)
        begin = settled if skip_warm_up else 0.0
        rows = t >= begin
        if rows.sum() < MIN_SAMPLES:
            raise InputError(f"{session.source}: {sensor}: {int(rows.sum())} samples are left after its warm-up "
                             f"(settled at {since[first] + settled:g} s); give --keep-warm-up to analyse it all, or "
                             "a longer recording")
        out["spans"][sensor] = {"start_s": float(since[first] + begin), "end_s": float(since[last - 1]),
                                "after_warm_up": bool(begin > 0)}
        axes = {}
        for k, axis in enumerate("xyz"):
            found = trends[axis]
            trend = found.trend(t[rows]) if found is not None else np.zeros(int(rows.sum()))
            axes[axis] = _axis(session, sensor, axis, part[rows, k], rate, trend)
            # a at t0_s, the stretch's start; settled_s, like every time of the report, from the recording's
            axes[axis]["start_trend"] = None if found is None else {
                **found.to_dict(), "t0_s": float(since[first]), "settled_s": float(since[first] + found.settled_s)}
        out["sensors"][sensor] = axes
    return out
