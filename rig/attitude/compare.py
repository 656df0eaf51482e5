"""Comparing an attitude estimate with the turntable's reference (the statistics of Table III).

The filter's navigation frame (magnetic ENU) and the reference's world frame differ by a constant
rotation C (declination, base tilt): R_est = C R_ref. C is estimated from a still interval (the first
hold) and removed; the error is then the rotation `R_ref^T C^T R_est` in the fixture frame, reported as
its roll, pitch and yaw (not as differences of Euler angles, which blow up near pitch +-90 deg).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rig.rotations import matrix_from_quat, quat_from_matrix
from rig.session_data import mean_rotation

AXES = ("roll", "pitch", "yaw")


def rpy_deg(R: np.ndarray) -> np.ndarray:
    """(n, 3) roll, pitch, yaw in degrees of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return np.degrees(Rotation.from_matrix(R).as_euler("ZYX"))[..., ::-1]


def estimate_alignment(q_est: np.ndarray, q_ref: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """C (world -> navigation) = mean over `rows` of R_est R_ref^T."""
    R_est, R_ref = matrix_from_quat(q_est[rows]), matrix_from_quat(q_ref[rows])
    return mean_rotation(quat_from_matrix(R_est @ R_ref.transpose(0, 2, 1)))


def alignment_summary(C: np.ndarray) -> dict:
    """How the navigation frame sits in the world frame: angle, axis and roll/pitch/yaw of C."""
    rv = Rotation.from_matrix(C).as_rotvec()
    angle = float(np.linalg.norm(rv))
    return {"matrix": C.tolist(), "angle_deg": float(np.degrees(angle)),
            "axis": (rv / angle).tolist() if angle > 0 else [0.0, 0.0, 1.0],
            "rpy_deg": dict(zip(AXES, rpy_deg(C).tolist()))}


def aligned(q_est: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Estimated fixture -> world matrices: C^T R_est."""
    return C.T @ matrix_from_quat(q_est)


def error_rpy_deg(R_ref: np.ndarray, R_est_world: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (deg) of the error rotation R_ref^T R_est, both fixture -> world."""
    return rpy_deg(np.einsum("nji,njk->nik", R_ref, R_est_world))


@dataclass
class AxisStats:
    rms: float
    mean: float
    sd: float
    corr: float     # Pearson correlation between estimated and reference angle (unwrapped)


def axis_stats(err: np.ndarray, est: np.ndarray, ref: np.ndarray) -> dict[str, AxisStats]:
    """Table III statistics per axis: error RMS, mean, SD (deg) and estimate/reference correlation."""
    out = {}
    for i, name in enumerate(AXES):
        e = err[:, i]
        a, b = np.unwrap(np.radians(est[:, i])), np.unwrap(np.radians(ref[:, i]))
        corr = float(np.corrcoef(a, b)[0, 1]) if a.std() > 0 and b.std() > 0 else float("nan")
        out[name] = AxisStats(float(np.sqrt(np.mean(e * e))), float(e.mean()), float(e.std(ddof=1)), corr)
    return out


@dataclass
class Comparison:
    """One estimator against the reference over the evaluated rows."""

    name: str
    stats: dict[str, AxisStats]
    alignment: dict
    err_deg: np.ndarray       # (n, 3) over all rows
    est_rpy_deg: np.ndarray   # (n, 3) aligned estimate
    rows: np.ndarray          # evaluated rows

    def rms(self) -> dict[str, float]:
        return {a: self.stats[a].rms for a in AXES}

    def to_dict(self) -> dict:
        return {"name": self.name, "stats": {a: asdict(s) for a, s in self.stats.items()},
                "rms_deg": self.rms(), "alignment": self.alignment}


def compare(name: str, q_est: np.ndarray, q_ref: np.ndarray, align_rows: np.ndarray,
            eval_rows: np.ndarray) -> Comparison:
    """Align on `align_rows`, then the Table III statistics over `eval_rows`."""
    C = estimate_alignment(q_est, q_ref, align_rows)
    R_ref = matrix_from_quat(q_ref)
    R_est = aligned(q_est, C)
    err = error_rpy_deg(R_ref, R_est)
    est_rpy, ref_rpy = rpy_deg(R_est), rpy_deg(R_ref)
    stats = axis_stats(err[eval_rows], est_rpy[eval_rows], ref_rpy[eval_rows])
    return Comparison(name, stats, alignment_summary(C), err, est_rpy, np.asarray(eval_rows))
