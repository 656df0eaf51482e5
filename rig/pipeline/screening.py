"""Which holds and moves of a session can be trusted, before any solver sees them.

It drops nothing silently: a hold that was not still (its noise far above the others', a gyro mean far from
the bias), that touches a saturated rail, or that has no samples is named with the reason, and so is a move
that touches such a hold or clips.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.saturation import rails
from rig.errors import CalibrationError
from rig.outliers import OUTLIER_SIGMAS
from rig.session_data import HoldStats, MoveStream, SessionData

# A hold whose noise (norm of the per-axis std) exceeds this multiple of the median hold's, plus
# one count for quantised, nearly noiseless sensors, was not still.
MOTION_STD_FACTOR = 5.0
MOTION_STD_FLOOR_COUNTS = 1.0
# A gyro hold mean further than this many robust sigmas from the bias, and by more than the half count that
# the mean of quantised samples without noise to dither them can be off anyway, was turning.
GYRO_MEAN_SIGMAS = 6.0
GYRO_MEAN_FLOOR_COUNTS = 0.5
# An axis whose consecutive samples at rest differ more often than this is dithered by noise (about 1 count or
# more): there, and only there, a hold or move piled up at the stream's extreme is clipped, not just quiet.
DITHERED_FRACTION = 0.5
# A move is not integrated across a hole in its samples longer than this many of its median sample intervals
# (and MOVE_GAP_MIN_S): the rotation in the hole is unknown. Nor across a recorded resume (a clock gap).
MOVE_GAP_INTERVALS = 10.0
MOVE_GAP_MIN_S = 0.2


def vec(v) -> str:
    return "[" + ", ".join(f"{x: .6g}" for x in np.asarray(v, dtype=float).ravel()) + "]"


def check_finite(session: SessionData) -> None:
    for label, arr in (("t", session.t), ("reference quaternion", session.q_ref)):
        bad = ~np.isfinite(np.asarray(arr, dtype=float).reshape(len(session.t), -1)).all(axis=1)
        if bad.any():
            raise CalibrationError(f"{session.source}: {label} is NaN/inf on {int(bad.sum())} row(s), first row "
                                   f"{int(np.argmax(bad))}; a session needs them on every row")
    if not (~session.is_move).any():
        raise CalibrationError(f"{session.source}: no 'hold' rows: nothing to calibrate from")


def warn_partial_nan(session: SessionData, warnings: list[str]) -> None:
    """Rows with NaN in some but not all axes are not 'no sample': they are damaged, and are not used."""
    for name, y in session.raw.items():
        nan = np.isnan(y)
        partial = nan.any(axis=1) & ~nan.all(axis=1)
        if partial.any():
            warnings.append(f"{name}: {int(partial.sum())} row(s) with NaN in some axes only (first row "
                            f"{int(np.argmax(partial))}); not used")


def warn_empty_holds(session: SessionData, holds: dict[str, HoldStats], settle_s: float, warnings: list[str]) -> None:
    """A hold without samples of a sensor (all NaN, or shorter than the settling time) is named, and so are
    the isolated outlier samples set aside in a hold (`rig.outliers`), with their count."""
    raw_steps = [j for j, _ in session.hold_rows(0.0)]
    settled = {j for j, _ in session.hold_rows(settle_s)}
    for j in raw_steps:
        if j not in settled:
            warnings.append(f"step {j}: hold shorter than the settling time {settle_s:g} s; not used")
    for name, h in holds.items():
        missing = sorted(settled - set(h.step.tolist()))
        if missing:
            warnings.append(f"{name}: no samples (NaN) in the hold(s) of step {', '.join(map(str, missing))}; not used")
        if h.outliers is not None and h.outliers.any():
            where = ", ".join(f"{int(n)} in step {int(j)}" for j, n in zip(h.step, h.outliers) if n)
            warnings.append(f"{name}: {int(h.outliers.sum())} isolated outlier sample(s) set aside ({where}): "
                            f"further than {OUTLIER_SIGMAS:g} robust sigmas from their hold's median")


def find_bad_holds(session: SessionData, holds: dict[str, HoldStats], settle_s: float) -> dict[int, str]:
    """Steps whose holds are untrustworthy for every sensor: motion on the board moves all its chips."""
    bad: dict[int, str] = {}

    def flag(step: int, reason: str) -> None:
        bad[step] = f"{bad[step]}; {reason}" if step in bad else reason

    rows = dict(session.hold_rows(settle_s))
    for name in session.sensors:
        for step, axis, rail in saturated_holds(session.raw[name], rows):
            flag(step, f"{name} axis {'xyz'[axis]} at its rail {rail:g} counts (saturated)")
        for step, reason in noisy_holds(holds[name]):
            flag(step, f"{name} {reason}: motion during the hold")
    if "gyro" in holds:
        for step, reason in turning_holds(holds["gyro"]):
            flag(step, f"gyro {reason}: the table was turning")
    return bad


def is_rail(v: float) -> bool:
    """Full-scale codes of integer ADCs: 2^k - 1, -2^k, -(2^k - 1) for k >= 7."""
    if not np.isfinite(v) or v != round(v):
        return False
    a = int(abs(v))
    all_ones = ((a + 1) & a) == 0 and a >= 127
    power_of_two = v < 0 and (a & (a - 1)) == 0 and a >= 128
    return all_ones or power_of_two


def rail_codes(y: np.ndarray, rest_rows: np.ndarray | None = None) -> list[tuple[int, float]]:
    """(axis, value) of each extreme of a stream that may be a rail: a full-scale code of an integer ADC, or, on
    an axis whose samples at rest (`rest_rows`, the settled holds' rows) are dithered by noise, any extreme at which
    the samples pile up (`rig.calibration.numerics.saturation.rails`). The codes alone missed a session another tool
    wrote: a logger that clips elsewhere (a range set below the ADC's, an offset already taken off) calibrated an
    accelerometer clipped in 2 holds 6 % off, a gyro clipped in its moves 27 % off, both with exit 0. Not on a
    quiet axis: a sensor without noise reads one code through a whole hold (or a cruise at constant rate), which
    piles up at the stream's extreme as clipping does. Each hold or move is still judged by its own pile
    (`piles_at`)."""
    out = []
    for axis in range(3):
        col = y[:, axis][~np.isnan(y[:, axis])]
        if col.size:
            out += [(axis, float(v)) for v in {col.min(), col.max()} if is_rail(float(v))]
    if rest_rows is not None and len(rest_rows) > 1:
        rest = y[np.sort(rest_rows)]
        rest = np.diff(rest[~np.isnan(rest).any(axis=1)], axis=0)   # a slower sensor's empty rows skipped
        dithered = (rest != 0).mean(axis=0) > DITHERED_FRACTION if len(rest) else np.zeros(3, dtype=bool)
        out += [(r.axis, r.value) for r in rails(y) if dithered[r.axis] and (r.axis, r.value) not in out]
    return out


def saturated_holds(y: np.ndarray, rows: dict[int, np.ndarray]) -> list[tuple[int, int, float]]:
    rails = rail_codes(y, np.concatenate(list(rows.values())) if rows else None)
    return [(step, axis, rail) for step, idx in rows.items() for axis, rail in rails
            if piles_at(y[idx, axis], rail, min_count=3)]


def piles_at(values: np.ndarray, rail: float, min_count: int) -> bool:
    """Clipping piles samples up at the rail; an unclipped noisy signal thins out towards its extreme.

    The rail code alone is not enough: a 4096 counts/g accelerometer legitimately reads 4095 at +1 g.
    """
    at = int(np.count_nonzero(values == rail))
    inner = int(np.count_nonzero(values == rail - np.sign(rail)))
    return at >= min_count and at > inner


def noisy_holds(h: HoldStats) -> list[tuple[int, str]]:
    if len(h.step) < 3:
        return []
    noise = np.linalg.norm(h.std, axis=1)
    median = float(np.median(noise))
    limit = MOTION_STD_FACTOR * median + MOTION_STD_FLOOR_COUNTS
    return [(int(j), f"noise {n:.3g} counts is {n / median if median else np.inf:.3g}x the median hold's {median:.3g}")
            for j, n in zip(h.step, noise) if n > limit]


def turning_holds(h: HoldStats) -> list[tuple[int, str]]:
    if len(h.step) < 3:
        return []
    centre = np.median(h.mean, axis=0)
    mad = 1.4826 * np.median(np.abs(h.mean - centre), axis=0)
    mean_noise = np.median(h.std / np.sqrt(np.maximum(h.count, 1))[:, None], axis=0)
    sigma = np.maximum(mad, mean_noise)
    sigma = np.where(sigma > 0, sigma, 0.5)  # quantised, noiseless: half a count
    off = np.abs(h.mean - centre)
    z = np.where(off > GYRO_MEAN_FLOOR_COUNTS, off / sigma, 0.0)
    return [(int(j), f"mean {vec(m)} counts is {zz.max():.3g} robust sigmas from the bias {vec(centre)}")
            for j, m, zz in zip(h.step, h.mean, z) if zz.max() > GYRO_MEAN_SIGMAS]


def without_steps(h: HoldStats, excluded: dict[int, str]) -> HoldStats:
    keep = ~np.isin(h.step, list(excluded))
    sel = lambda a: None if a is None else a[keep]  # noqa: E731
    return HoldStats(h.step[keep], h.mean[keep], h.std[keep], h.count[keep], h.R[keep], h.t_start[keep],
                     h.t_end[keep], sel(h.temp_c), sel(h.vsupply_v), sel(h.outliers))


def trusted_moves(session: SessionData, excluded: dict[int, str], warnings: list[str], settle_s: float = 0.0,
                   rest: np.ndarray | None = None, still_counts: np.ndarray | None = None) -> list[MoveStream]:
    holds = session.hold_rows(settle_s)
    order = [j for j, _ in holds]
    next_step = dict(zip(order[:-1], order[1:]))
    bounds = {j: (float(session.t[a[-1]]), float(session.t[b[0]])) for (j, a), (_, b) in zip(holds[:-1], holds[1:])}
    y_all = session.raw["gyro"]
    rails = rail_codes(y_all, np.concatenate([rows for _, rows in holds]) if holds else None)
    out = []
    resumes = resume_times(session)
    for m in session.moves("gyro", settle_s):
        end = next_step.get(m.step)
        if m.step in excluded or end in excluded:
            warnings.append(f"gyro: move {m.step} -> {end} not used (touches an excluded hold)")
            continue
        gap = move_gap(m, resumes, bounds.get(m.step))
        if gap:
            warnings.append(f"gyro: move {m.step} -> {end} not used: it {gap}")
            continue
        hit = [(axis, rail) for axis, rail in rails if piles_at(m.y[:, axis], rail, min_count=2)]
        if hit:
            axis, rail = hit[0]
            warnings.append(f"gyro: move {m.step} -> {end} not used: axis {'xyz'[axis]} at its rail {rail:g} "
                            "counts (rate beyond the range)")
            continue
        out.append(m.trimmed_to_motion(rest=rest, still_counts=still_counts))
    return out


def resume_times(session: SessionData) -> list[float]:
    """Session times at which a resumed run started (the `resumes` the session store records)."""
    out = []
    for mark in session.meta.get("resumes") or []:
        try:
            out.append(float(mark["t_s"]))
        except (KeyError, TypeError, ValueError):
            continue
    return sorted(t for t in out if np.isfinite(t))


def move_gap(m: MoveStream, resumes: list[float], bounds: tuple[float, float] | None = None) -> str | None:
    """Why a move stream cannot be integrated as one (a resume inside it, a hole in its samples), or None.

    `bounds`: the times of the last row of the hold it leaves and the first of the hold it reaches; a stream that
    starts or ends away from them (its first or last samples missing) has a hole there, judged like any other."""
    for t in resumes:
        if m.t[0] < t <= m.t[-1]:
            return f"spans the resume at session time {t:.3f} s (a clock gap)"
    t = m.t if bounds is None else np.concatenate([[min(bounds[0], m.t[0])], m.t, [max(bounds[1], m.t[-1])]])
    dt = np.diff(t)
    if dt.size >= 3:
        worst = int(np.argmax(dt))
        if dt[worst] > max(MOVE_GAP_MIN_S, MOVE_GAP_INTERVALS * float(np.median(dt))):
            return f"has no samples for {dt[worst]:.3g} s after {t[worst]:.3f} s"
    return None
