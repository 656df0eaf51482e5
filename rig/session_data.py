"""A measured session in memory: the arrays behind the interchange layout (`session-csv.md`).

Importers (interchange CSV, the SQLite store) build a `SessionData`; the calibration, attitude and
discrepancy code read hold statistics and move streams from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.outliers import isolated_outliers
from rig.units import STANDARD_GRAVITY
from rig.rotations import matrix_from_quat, quat_from_matrix


def no_reference(n: int) -> np.ndarray:
    """The `q_ref` of a recording without a reference attitude: n rows of NaN that are one row in memory (a read-only
    broadcast view). Written out, the 32 bytes a row of a 6-hour log at 100 Hz were 66 MiB, held by the session and
    by every one of its twin's replicas alive at once."""
    return np.broadcast_to(np.full(4, np.nan), (n, 4))


@dataclass
class HoldStats:
    """Per-hold statistics of one sensor, one row per hold in time order."""

    step: np.ndarray        # (k,) orientation index j
    mean: np.ndarray        # (k, 3) raw counts
    std: np.ndarray         # (k, 3)
    count: np.ndarray       # (k,)
    R: np.ndarray           # (k, 3, 3) fixture -> world reference at the hold
    t_start: np.ndarray     # (k,)
    t_end: np.ndarray       # (k,)
    temp_c: np.ndarray | None = None      # (k,) mean board temperature
    vsupply_v: np.ndarray | None = None   # (k,)
    outliers: np.ndarray | None = None    # (k,) isolated outlier samples set aside (rig.outliers)


SETTLE_NOISE_FACTOR = 6.0
SETTLE_FLOOR_RAD = float(np.radians(0.005))
# A pause longer than this inside a hold's rows is a new visit (the table was away, or the rig was stopped),
# settled anew; shorter holes are lost reads (a retried bus or table request: 0.05-0.2 s). Nor shorter than
# VISIT_GAP_INTERVALS of the hold rows' own median interval: a logger writing 1 row a second (another lab's, the
# static sensors only) has every row 1 s after the last, and with 0.5 s alone each row was a visit of its own,
# emptied by the settling time: no hold was left, and the refusal blamed the number of orientations.
VISIT_GAP_S = 0.5
VISIT_GAP_INTERVALS = 10.0


@dataclass
class MoveStream:
    """Raw samples of one sensor from the last sample of hold j to the first of hold j+1."""

    step: int
    t: np.ndarray           # (m,)
    y: np.ndarray           # (m, 3) raw counts
    R_start: np.ndarray     # (3, 3) fixture -> world at hold j
    R_end: np.ndarray       # (3, 3) at hold j+1
    q_ref: np.ndarray | None = None   # (m, 4) reference orientation on the same rows, where known

    @property
    def known_rotation(self) -> np.ndarray:
        """R_j^T R_{j+1}: the rotation the integrated gyro must reproduce (conventions.md)."""
        return self.R_start.T @ self.R_end

    def trimmed_to_motion(self, margin_s: float = 0.05, still_rad_s: float = 0.01, rest: np.ndarray | None = None,
                          still_counts: np.ndarray | None = None) -> "MoveStream":
        """The stream cut to where the table turns, plus a margin at both ends.

        Outside that span the table stands still, so integrating there adds only rate noise (it grows as the
        square root of the time integrated). The span is where the reference shows motion and, given the
        sensor's `rest` reading and a per-axis `still_counts` threshold, also where the sensor still shows it:
        a low-passed or delayed gyro (a 5 Hz DLPF lags by ~30 ms) turns on after the encoders stopped, and
        cutting that tail off costs H ~0.07 % at 40 ms. Unchanged when neither shows motion, or without a
        reference (a session that logs only hold orientations).
        """
        if self.q_ref is None or len(self.t) < 3:
            return self
        dots = np.abs(np.einsum("ij,ij->i", self.q_ref[1:], self.q_ref[:-1])).clip(max=1.0)
        speed = 2 * np.arccos(dots) / np.diff(self.t)
        moving = np.flatnonzero(speed > still_rad_s)
        if rest is not None and still_counts is not None:
            felt = np.flatnonzero((np.abs(self.y - rest) > still_counts).any(axis=1))
            moving = np.union1d(moving, np.r_[felt, felt - 1].clip(0, len(self.t) - 2))
        if moving.size == 0:
            return self
        keep = (self.t >= self.t[moving[0]] - margin_s) & (self.t <= self.t[moving[-1] + 1] + margin_s)
        if keep.sum() < 2:
            return self
        return MoveStream(self.step, self.t[keep], self.y[keep], self.R_start, self.R_end, self.q_ref[keep])


@dataclass
class SessionData:
    """Row-aligned arrays of a session; a sensor's cells are NaN where it had no new sample."""

    t: np.ndarray                       # (n,) s
    is_move: np.ndarray                 # (n,) bool: phase == 'move'
    step: np.ndarray                    # (n,) int
    q_ref: np.ndarray                   # (n, 4) fixture -> world, scalar first
    raw: dict[str, np.ndarray]          # sensor -> (n, 3) float, NaN where empty
    columns: dict[str, list[str]]       # sensor -> raw column names in sensor-axis order
    gravity: float = STANDARD_GRAVITY
    field_uT: float | None = None
    sample_rate_hz: float | None = None
    table_deg: np.ndarray | None = None  # (n, 2) outer, inner
    temp_c: np.ndarray | None = None
    vsupply_v: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    source: str = "<memory>"

    @property
    def sensors(self) -> list[str]:
        return list(self.raw)

    def hold_steps(self) -> np.ndarray:
        return np.unique(self.step[~self.is_move])

    def hold_rows(self, settle_s: float = 0.0) -> list[tuple[int, np.ndarray]]:
        """(step, row indices) of each hold in time order, dropping `settle_s` at its start.

        `settle_s` is the least that is dropped: where the reference still moves after it, the rows up to its
        last excursion in the hold's first half are dropped too (see `_settled`).
        A hold visited twice (a repeated hold after a bump) counts once: its last visit. Visits with no move
        rows between them (the hold held again after a resume or a redone step: the moves away and back were
        not kept) form one hold, each visit settled on its own, since the table came to it anew.
        """
        rows = np.flatnonzero(~self.is_move)
        if rows.size == 0:
            return []
        apart = (np.diff(rows) != 1) | (np.diff(self.step[rows]) != 0)
        dt = np.diff(self.t[rows])
        gap = max(VISIT_GAP_S, VISIT_GAP_INTERVALS * float(np.median(dt))) if dt.size else VISIT_GAP_S
        breaks = np.flatnonzero(apart | (dt > gap)) + 1
        out: dict[int, np.ndarray] = {}
        joined = np.r_[False, ~apart[breaks - 1]] if breaks.size else np.array([False])
        for seg, same_visit_run in zip(np.split(rows, breaks), joined):
            step = int(self.step[seg[0]])
            if settle_s > 0:
                seg = self._settled(seg[self.t[seg] >= self.t[seg[0]] + settle_s])
            if same_visit_run and step in out:
                seg = np.concatenate([out[step], seg])
            if seg.size:
                out[step] = seg
        return sorted(out.items(), key=lambda kv: self.t[kv[1][0]])

    def _settled(self, seg: np.ndarray) -> np.ndarray:
        """The hold's rows from where its reference has come to rest.

        A table that rings longer than the fixed settling time would put motion into the hold means and cut
        the moves short. Rest is judged against the hold's second half: a row of the first half is still
        moving when it is further from that half's mean orientation than SETTLE_NOISE_FACTOR times the
        half's own RMS scatter (encoder steps or tracker noise), or SETTLE_FLOOR_RAD if the reference is
        quiet. Excursions in the second half are left to the motion checks of the pipeline.
        """
        n = len(seg)
        if n < 8:
            return seg
        q = self.q_ref[seg]
        tail = q[n // 2:]
        tail = np.where((tail @ tail[-1])[:, None] < 0, -tail, tail)
        qm = tail.mean(axis=0)
        qm /= np.linalg.norm(qm)
        angle = 2 * np.arccos(np.abs(q @ qm).clip(max=1.0))
        limit = max(SETTLE_NOISE_FACTOR * float(np.sqrt(np.mean(angle[n // 2:] ** 2))), SETTLE_FLOOR_RAD)
        moving = np.flatnonzero(angle[: n // 2] > limit)
        return seg[moving[-1] + 1:] if moving.size else seg

    def holds(self, sensor: str, settle_s: float = 0.0) -> HoldStats:
        y = self.raw[sensor]
        steps, means, stds, counts, Rs, t0, t1, temps, vs, spikes = [], [], [], [], [], [], [], [], [], []
        for j, idx in self.hold_rows(settle_s):
            vals = y[idx]
            vals = vals[~np.isnan(vals).any(axis=1)]
            if len(vals) == 0:
                continue
            outliers = isolated_outliers(vals)
            vals = vals[~outliers]
            spikes.append(int(outliers.sum()))
            steps.append(j)
            means.append(vals.mean(axis=0))
            stds.append(vals.std(axis=0, ddof=1) if len(vals) > 1 else np.zeros(3))
            counts.append(len(vals))
            Rs.append(mean_rotation(self.q_ref[idx]))
            t0.append(self.t[idx[0]])
            t1.append(self.t[idx[-1]])
            temps.append(np.nanmean(self.temp_c[idx]) if self.temp_c is not None else np.nan)
            vs.append(np.nanmean(self.vsupply_v[idx]) if self.vsupply_v is not None else np.nan)
        return HoldStats(np.array(steps, dtype=int), np.array(means).reshape(-1, 3),
                         np.array(stds).reshape(-1, 3), np.array(counts, dtype=int),
                         np.array(Rs).reshape(-1, 3, 3), np.array(t0), np.array(t1),
                         np.array(temps) if self.temp_c is not None else None,
                         np.array(vs) if self.vsupply_v is not None else None, np.array(spikes, dtype=int))

    def moves(self, sensor: str, settle_s: float = 0.0) -> list[MoveStream]:
        """Streams between consecutive holds (in time order), each including its bounding samples.

        With `settle_s`, a stream runs on to the first settled row of the next hold and both reference
        orientations come from settled rows, so ringing at the start of a hold is integrated, not ignored.
        """
        y = self.raw[sensor]
        have = ~np.isnan(y).any(axis=1)
        holds = self.hold_rows(settle_s)
        out = []
        for (j, a), (k, b) in zip(holds[:-1], holds[1:]):
            lo, hi = a[-1], b[0]
            idx = np.arange(lo, hi + 1)
            idx = idx[have[idx]]
            if len(idx) < 2:
                continue
            out.append(MoveStream(j, self.t[idx], y[idx], mean_rotation(self.q_ref[a]), mean_rotation(self.q_ref[b]),
                                  self.q_ref[idx]))
        return out


def with_configuration_facts(data: SessionData) -> SessionData:
    """What the interchange layout carries beside the arrays, taken for a stored session from its configuration
    snapshot: the sample rate and the table's axes (`meta["table"]`)."""
    config = data.meta.get("config") or {}
    geometry = config.get("geometry") or {}
    if data.sample_rate_hz is None and (config.get("schedule") or {}).get("rate_hz"):
        data.sample_rate_hz = float(config["schedule"]["rate_hz"])
    table = {k: geometry[k] for k in ("outer_axis_world", "inner_axis_fixture") if k in geometry}
    if table:
        data.meta.setdefault("table", table)
    return data


def filled(y: np.ndarray) -> np.ndarray:
    """A stream (n, 3) with its empty rows (read errors, slower sensors) interpolated over the sample index: for
    calibrated series that must be continuous (a motion's rate, the specific force along a replay)."""
    have = ~np.isnan(y).any(axis=1)
    idx = np.arange(len(y))
    return np.stack([np.interp(idx, idx[have], y[have, k]) for k in range(y.shape[1])], axis=1)


def mean_rotation(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of the (sign-aligned, normalised) mean of scalar-first quaternions."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    q = np.where((q @ q[0])[:, None] < 0, -q, q)
    m = q.mean(axis=0)
    return matrix_from_quat(m / np.linalg.norm(m))


def quats(R: np.ndarray) -> np.ndarray:
    return quat_from_matrix(R)
