"""What a recording must not feed into its calibration: an axis stuck at one value, and samples pinned at a rail
(saturated). Each is found in the data, named with the column the user's file calls it, and either left out of
the fits with a warning or refused in one line (`rig.calibration.recordings.recording`).
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from rig.calibration.numerics.saturation import Rail, pinned_rows, rail_names
from rig.calibration.recordings.segments import Pose, Turn
from rig.errors import CalibrationError
from rig.session_data import SessionData


def unsaturated_poses(session: SessionData, poses: list[Pose]) -> tuple[list[Pose], list[tuple[str, str]]]:
    """The poses with no accelerometer or magnetometer sample at a rail, and (warning, reason) for each sensor
    that had some: a clipped pose reads less than the vector (an axis at 8 m/s^2 where gravity along it gives
    9.8), which the fit would take for scale and offset. The motions either side of a left-out pose join into
    one (`recording_gyro.whole_carries`), which still carries gravity from the pose before it to the next."""
    out = []
    for sensor in ("accel", "mag"):
        found, hit = _rails_of(session, sensor)
        spoiled = [p.name for p in poses if hit is not None and hit[p.rows].any()]
        if spoiled:
            kept = [p for p in poses if not hit[p.rows].any()]
            names = rail_names(sensor, found, imported_columns(session, sensor))
            out.append((f"{sensor}: {names}: {len(spoiled)} of {len(poses)} poses read a sample at a rail and were "
                        f"left out ({', '.join(spoiled)}; saturated: the pose's {sensor} beyond the range)",
                        f"{len(spoiled)} poses with {names} are left out (saturated)"))
            poses = kept
    return poses, out


def unclipped_turns_and_motions(session: SessionData, poses: list[Pose], turns: list[Turn],
                                carries: list[tuple[int, int]]) -> tuple[list[Turn], list[tuple[int, int]],
                                                                          list[tuple[str, str]]]:
    """The turns and motions between poses with no gyro sample at a rail, and (warning, reason) if some had one:
    a clipped rate sums to less than the turn, and a fit to it anyway scales H (a gyro clipped at 250 deg/s in
    hand motions came out 20 % off)."""
    found, hit = _rails_of(session, "gyro")
    if hit is None:
        return turns, carries, []
    bad_turns = [k for k, t in enumerate(turns) if hit[t.rows].any()]
    bad_carries = [c for c, (i, j) in enumerate(carries) if hit[poses[i].rows[-1]:poses[j].rows[0] + 1].any()]
    if not bad_turns and not bad_carries:
        return turns, carries, []
    names = rail_names("gyro", found, imported_columns(session, "gyro"))
    left = f"{len(bad_turns)} of {len(turns)} turns and {len(bad_carries)} of {len(carries)} motions between poses"
    return ([t for k, t in enumerate(turns) if k not in bad_turns],
            [ij for c, ij in enumerate(carries) if c not in bad_carries],
            [(f"gyro: {names}: {left} read a sample at a rail and were left out (saturated: the rate beyond the "
              "range is lost)", f"{left} with {names} are left out (saturated)")])


def _rails_of(session: SessionData, sensor: str) -> tuple[list[Rail], np.ndarray | None]:
    """A sensor's rails and the rows that read one (None without either)."""
    if sensor not in session.raw:
        return [], None
    found, hit = pinned_rows(session.raw[sensor])
    return found, (hit if found else None)


def imported_columns(session: SessionData, sensor: str) -> list[str] | None:
    """The sensor's columns as the imported file calls them (None for a session the rig recorded)."""
    return ((session.meta.get("imported") or {}).get("columns") or {}).get(sensor)


@contextmanager
def refused_for_saturation(session: SessionData, reasons: list[str]):
    """A fit that cannot be made from what saturation left is refused naming the recording and the saturation,
    in one line: the fit's own reason ('3 poses ... need at least 9') would blame poses the user did record."""
    try:
        yield
    except CalibrationError as exc:
        if not reasons:
            raise
        raise CalibrationError(f"{session.source}: {exc}, once {'; '.join(reasons)}") from None


def check_no_stuck_axis(session: SessionData) -> None:
    """Refuse a sensor axis that holds one value on every row (stuck, disconnected, or a column of zeros).

    Nothing calibrates it: the fits left its column of H where they started (a gyro's at 1.8 with a standard
    deviation of 0, an accelerometer's turned into a det(H) = 0 gyro error), and exited 0 with a warning about
    rests or went on to name effects in it. The column is named as the imported file calls it.
    """
    for sensor, y in session.raw.items():
        for k in range(y.shape[1]):
            v = y[:, k][~np.isnan(y[:, k])]
            if len(v) > 1 and np.ptp(v) == 0:
                column = (imported_columns(session, sensor) or session.columns.get(sensor, "xyz"))[k]
                raise CalibrationError(f"{session.source}: {sensor}.{'xyz'[k]} (column '{column}') holds the same "
                                       f"value {v[0]:g} on all {len(v)} rows: a stuck axis cannot be calibrated")
