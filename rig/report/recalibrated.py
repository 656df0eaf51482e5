"""A folder's calibration replaced (`rig calibrate --from SESSION --out DIR --force`): its report made again
from the same calibration, so `calibration.json` and `report.md` never disagree. Without `--force` an existing
calibration is never replaced."""

from __future__ import annotations

from pathlib import Path

from rig.calibration.numerics.result import TriadCalibration
from rig.errors import InputError
from rig.pipeline.writing import CALIBRATION_FILE
from rig.report.calibration_report import write_report
from rig.session_data import SessionData

REPORT_FILES = ("report.md", "report.json")


def refuse_overwrite(out: Path, force: bool) -> None:
    """InputError when `out` holds a calibration and `force` is not given (nothing is changed)."""
    existing = Path(out) / CALIBRATION_FILE
    if existing.exists() and not force:
        report = " and its report.md" if (Path(out) / "report.md").exists() else ""
        raise InputError(f"{existing}: a calibration is there already; give --force to replace it{report} "
                         "(the report is then written again to match), or another --out")


def report_again(out: Path, session: SessionData | None, sensors: dict[str, TriadCalibration]) -> str | None:
    """After `out/calibration.json` was replaced: the report of `out`, if it has one, written again for
    `sensors` (with the session's own limits and truth; its figures drawn again if it had any), or, for data
    that is no session (imu_tk files), removed. A line saying what was done, or None without a report."""
    out = Path(out)
    if not (out / "report.md").exists():
        return None
    if session is None:
        for name in REPORT_FILES:
            (out / name).unlink(missing_ok=True)
        return f"removed {out / 'report.md'}: it described the calibration just replaced"
    meta = session.meta or {}
    had_figures = any(out.glob("*_norms.png")) or any(out.glob("*_moves.png")) or any(out.glob("*_ellipsoid.png"))
    path = write_report(out, session, sensors, gravity=session.gravity, field_uT=session.field_uT,
                        truth=meta.get("truth"), limits=(meta.get("config") or {}).get("limits"), metadata=meta,
                        plots=had_figures)
    return f"wrote {path} again for the new calibration"
