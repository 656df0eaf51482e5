"""The rests a recording's segments do not name, and the motions into and out of them.

A hand puts the unit down before and after each turn and between faces; no segment names those stretches, so no
fit on the segments sees them. Their accelerometer samples, and the gravity the gyro carries across the motions
that start or end at them, are held out for every calibration fitted on the segments: ours and a peer's alike
(`rig.calibration.recordings.heldout`).
"""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.recording import RecordingCalibration
from rig.calibration.numerics.static_detect import moving_variance_norm, window_samples
from rig.session_data import SessionData

REST_WINDOW_S = 0.5
REST_K = 6.0                  # imu_tk's chosen threshold multiplier on its Xsens data
REST_MIN_S = 1.0


def unlabelled_rests(session: SessionData, rec: RecordingCalibration, k: float = REST_K) -> list[np.ndarray]:
    """Rows of the rests outside every segment: samples whose windows of `REST_WINDOW_S` are as quiet as the
    named poses' (accelerometer and, where recorded, gyroscope variance below k times the median over the poses:
    imu_tk's detector with the poses as the quiet reference; the gyro sees a turn about the vertical that the
    accelerometer does not), touching no segment (a rest that runs into a named pose is that pose's placement), at
    least `REST_MIN_S` long after a quarter window is trimmed from each end (the hand settling)."""
    if not rec.poses:
        return []
    win = window_samples(session.t, REST_WINDOW_S)
    if win >= len(session.t):
        return []
    quiet = np.ones(len(session.t), dtype=bool)
    for sensor in ("accel", "gyro"):
        if sensor in session.raw:
            y = session.raw[sensor]
            level = float(np.median([np.linalg.norm(np.nanvar(y[p.rows], axis=0, ddof=1)) for p in rec.poses]))
            quiet &= np.nan_to_num(moving_variance_norm(y, win), nan=np.inf) < k * level
    named = np.zeros(len(session.t), dtype=bool)
    for seg in session.meta.get("segments") or []:
        named |= (session.t >= seg["t0"]) & (session.t <= seg["t1"])
    edges = np.diff(np.concatenate([[0], quiet.astype(np.int8), [0]]))
    out = []
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1):
        if named[a:b + 1].any():
            continue
        a, b = a + win // 4, b - win // 4
        if b > a and session.t[b] - session.t[a] >= REST_MIN_S:
            out.append(np.arange(a, b + 1))
    return out


def rest_motions(session: SessionData, rec: RecordingCalibration,
                 rests: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """(rows before, rows after) of each motion into or out of a rest: two quiet stretches next to each other in
    time (the named poses and `rests`), at least one of them a rest, with no segment between them. A turn between
    two rests is a segment, fitted by both calibrations, so its motion is not one of these."""
    stretches = sorted([(p.rows, False) for p in rec.poses] + [(r, True) for r in rests], key=lambda s: s[0][0])
    segments = session.meta.get("segments") or []
    out = []
    for (a, a_rest), (b, b_rest) in zip(stretches[:-1], stretches[1:]):
        t0, t1 = session.t[a[-1]], session.t[b[0]]
        if (a_rest or b_rest) and not any(t0 < s["t0"] and s["t1"] < t1 for s in segments):
            out.append((a, b))
    return out
