"""Ours beside the peers on the peers' own recordings, scored by what each predicts for data left out of its fit
prints JSON.

* imucal 2.6.0 (the `peers` extra) runs its Ferraris calibration on its two example sessions as its docs do
  (`examples/basic_ferraris.py`: the continuous SI file and its section list, 102.4 Hz; its tests: the pre-cut
  file in counts, 204.8 Hz), with gravity 9.81 (its default, also given to ours) and the turn sense the data
  show (the importer's; imucal's default -360 deg fits the SI file, the pre-cut one turns the other way).
* imu_tk: its published parameters for the Xsens recording (tests/data/imu_tk-xsens/PROVENANCE.md, its
  `test_imu_calib` run), g = 9.81744.
* tomisuarez2/ImuCalibration (a Python port of imu_tk): its published parameters for its own MPU-6050 session
  (tests/data/mpu6050-tomisuarez2, PROVENANCE.md), read from its files; g = 9.80665, as it was run.
* mikoff/imu-calib (Mikov et al., ICINS 2020): its own method run on its own MPU-9150 logs (`mikov_peer.py`, the
  parameters in tests/data/mikoff-imu-calib/peer_params.json); imu0.log from tests/data, all five with
  --mikov-repo DIR (a checkout); g = 9.81, as its code fits.
Ours is `calibrate_recording` on the imported session as `rig calibrate` runs it (the gyro's g-sensitivity taken
into its calibration where the poses show it, `rig.calibration.recordings.g_sensitivity`). Held-out scores
(rig.calibration.recordings.heldout): leave one pose / turn / motion out and refit. A peer whose closed form cannot
refit without a piece (imucal needs all six faces and all three turns; imu_tk's parameters are published, fitted on
every pose and motion) is scored in-sample there, which favours the peer; pieces no fit saw (imucal never uses the
motions between faces or the rests outside its sections) are held out for both.
Usage: python benchmarks/bench_recordings.py [--data DIR] [--only si,raw,xsens,mpu,mikov] [--mikov-repo DIR]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT)]

from rig.calibration.recordings.carry_weight import angle_directions  # noqa: E402
from rig.calibration.turntable.gyro import MoveSet, integrated_quats  # noqa: E402
from rig.calibration.recordings.heldout import (  # noqa: E402
    carry_error_deg, heldout_scores, pose_errors, score_series, scoring_layout, series)
from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.calibration.recordings.recording_fits import gyro_rotation_fit  # noqa: E402
from rig.calibration.recordings.recording_gyro import motion  # noqa: E402
from rig.calibration.recordings.recording_vector import gravity_directions  # noqa: E402
from rig.calibration.numerics.static_detect import find_initial_rest, initial_interval  # noqa: E402
from rig.calibration.recordings.turntable_free import turntable_free_accel  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402
from rig.io.import_csv import import_csv  # noqa: E402
from rig.io.import_ferraris import import_ferraris  # noqa: E402
from rig.io.import_imu_tk import import_imu_tk  # noqa: E402
from rig.rotations import axis_angle_matrix  # noqa: E402
from rig.session_data import MoveStream  # noqa: E402
from mikov_peer import as_rig  # noqa: E402

IMUCAL_GRAVITY = 9.81
XSENS_GRAVITY = 9.81744
# imu_tk on its Xsens data, anchors-calibration.md 4.2 (u = H (y - B); counts -> m/s^2 and rad/s)
IMU_TK_PUBLISHED = {
    "accel": {"B": [33124.1825646, 33275.1794342, 32364.4156494],
              "H": [[0.00241278462813, -8.15343126073e-06, -2.14793765282e-05],
                    [0.0, 0.00242712279558, -5.14510749167e-05],
                    [0.0, 0.0, 0.00241168027551]]},
    "gyro": {"B": [32777.139944, 32459.8028788, 32511.847461],
             "H": [[2.09294525942e-04, 1.24602919326e-06, 2.32737584258e-07],
                   [1.69279890751e-06, 2.09898539736e-04, -1.12192512433e-05],
                   [5.29655826242e-06, -5.35514746076e-07, 2.09482984218e-04]]},
}
OURS = functools.partial(calibrate_recording, g_sensitivity=True)       # as `rig calibrate` writes it
QUANTITY = {"accel_pose_rms": "accel |a|-g RMS over the samples of each pose, m/s^2",
            "accel_pose_mean_error": "accel |mean a|-g RMS over poses, m/s^2",
            "accel_rest_rms": "accel |a|-g RMS at rests outside the segments, m/s^2",
            "accel_rest_mean_error": "accel |mean a|-g RMS over rests outside the segments, m/s^2",
            "gyro_turn_deg": "gyro turn angle error RMS, deg",
            "gyro_carry_deg": "gyro gravity carried between poses, angle RMS, deg",
            "gyro_rest_carry_deg": "gyro gravity carried into and out of rests outside the segments, angle RMS, deg"}
IMUCAL_NEVER_FITS = {"accel_rest_rms", "accel_rest_mean_error", "gyro_carry_deg",     # its Ferraris fit uses the
                     "gyro_rest_carry_deg"}                                           # sections only
IMU_TK_RUN_S = 1.0          # anchors 4.2: "run time ~ 1 s" (not measured here)
MIKOV = ROOT / "tests" / "data" / "mikoff-imu-calib"
MIKOV_GRAVITY = 9.81        # its accelerometer fit takes gravity as 9.81 (code/cost_functions.py, residual_acc)


def imucal_ferraris(session, *, csv: Path | None = None, sections: Path | None = None, annotated: Path | None = None,
                    rate_hz: float, unit: str):
    """imucal's calibration of its own file, loaded as its docs load it; (CalibrationInfo, seconds)."""
    import pandas as pd
    from imucal import FerrarisCalibration, ferraris_regions_from_df, ferraris_regions_from_section_list

    t0 = time.perf_counter()
    if annotated is not None:
        regions = ferraris_regions_from_df(pd.read_csv(annotated, header=0, index_col=[0, 1]))
    else:
        data = pd.read_csv(csv, header=0, index_col=0)
        regions = ferraris_regions_from_section_list(data, pd.read_json(sections).T)
    sense = np.sign([s["angle_deg"] for s in session.meta["segments"] if s["kind"] == "rotation"]).mean()
    cal = FerrarisCalibration(grav=session.gravity, expected_angle=360.0 * (1 if sense > 0 else -1))
    info = cal.compute(regions, sampling_rate_hz=rate_hz, from_acc_unit=unit, from_gyr_unit=unit if unit == "a.u."
                       else "deg/s")
    return info, time.perf_counter() - t0


def imucal_on_session(session):
    """imucal's calibration of any Ferraris-style session (six faces with the axis up, a turn about each axis),
    its regions cut from the session's own segments; (CalibrationInfo, seconds)."""
    import pandas as pd
    from imucal import FerrarisCalibration, ferraris_regions_from_df

    t0 = time.perf_counter()
    names = {"+x": "x_p", "-x": "x_a", "+y": "y_p", "-y": "y_a", "+z": "z_p", "-z": "z_a"}
    parts, rows = [], []
    for seg in session.meta["segments"]:
        part = names.get(seg.get("up")) if seg["kind"] == "static" else seg["axis"][-1] + "_rot"
        idx = np.flatnonzero((session.t >= seg["t0"]) & (session.t <= seg["t1"]))
        parts += [part] * len(idx)
        rows.append(idx)
    idx = np.concatenate(rows)
    df = pd.DataFrame(np.hstack([session.raw["accel"][idx], session.raw["gyro"][idx]]),
                      columns=["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"], index=pd.Index(parts, name="part"))
    sense = np.sign([s["angle_deg"] for s in session.meta["segments"] if s["kind"] == "rotation"]).mean()
    counts = session.meta["units"]["accel"] == "counts"
    cal = FerrarisCalibration(grav=session.gravity, expected_angle=360.0 * (1 if sense > 0 else -1))
    info = cal.compute(ferraris_regions_from_df(df), sampling_rate_hz=session.sample_rate_hz,
                       from_acc_unit="a.u." if counts else "m/s^2", from_gyr_unit="a.u." if counts else "deg/s")
    return info, time.perf_counter() - t0


def imucal_series(info, session) -> dict[str, np.ndarray]:
    """imucal's calibration applied to the session's raw rows (its g-sensitivity term included): m/s^2, rad/s."""
    import pandas as pd

    df = pd.DataFrame(np.hstack([session.raw["accel"], session.raw["gyro"]]),
                      columns=["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"])
    out = info.calibrate_df(df, info.from_acc_unit, info.from_gyr_unit)
    return {"accel": out[["acc_x", "acc_y", "acc_z"]].to_numpy(),
            "gyro": np.radians(out[["gyr_x", "gyr_y", "gyr_z"]].to_numpy())}


def published_series(params: dict, session) -> dict[str, np.ndarray]:
    return {s: (session.raw[s] - np.array(p["B"])) @ np.array(p["H"]).T for s, p in params.items()}


def tomisuarez2_published(folder: Path) -> dict:
    """Its accelerometer `a = T K (y + b)` and gyro `w = T K (y - bias)` (PROVENANCE.md) as u = H (y - B)."""
    acc = np.loadtxt(folder / "params_acc.csv")
    gyr = np.loadtxt(folder / "params_gyro.csv")
    yz, zy, zx = acc[:3]
    Ta = np.array([[1.0, -yz, zy], [0.0, 1.0, -zx], [0.0, 0.0, 1.0]])
    yz, zy, xz, zx, xy, yx = gyr[:6]
    Tg = np.array([[1.0, -yz, zy], [xz, 1.0, -zx], [-xy, yx, 1.0]])
    return {"accel": {"B": (-acc[6:9]).tolist(), "H": (Ta @ np.diag(acc[3:6])).tolist()},
            "gyro": {"B": gyr[9:12].tolist(), "H": (Tg @ np.diag(gyr[6:9])).tolist()}}


def initial_rest_s(laid) -> float:
    """The initial rest imu_tk's method is given: the recording's own where its meta says it, else the one rig
    finds in the data (a user of imu_tk sets it to the recording's rest; its 50 s default fits only its own)."""
    given = laid.meta.get("initial_rest_s")
    if given:
        return float(given)
    return find_initial_rest(laid.t, laid.raw["accel"], laid.raw.get("gyro")).seconds


def imu_tk_method_carries(laid, full) -> list[float]:
    """imu_tk's gyro method held out, motion by motion: B the mean of the initial rest, H carrying the gravity
    direction of each pose (unweighted unit-vector residuals, MultiPosGyroResidual) across every other motion
    (rig's re-implementation; on all motions it gives imu_tk's published H to 0.2 % on the diagonal), with imu_tk's
    accelerometer (upper-triangular H fitted to the first 100 samples of each pose, `turntable_free_accel`)."""
    rest = initial_rest_s(laid)
    B0 = laid.raw["gyro"][:initial_interval(laid.t, rest)].mean(axis=0)
    accel = turntable_free_accel(laid.t, laid.raw["accel"], gravity=laid.gravity, init_static_s=rest)
    g = gravity_directions(laid, accel, full.poses)
    streams = [motion(laid, full.poses[i], full.poses[j]) for i, j in full.carries]
    out = []
    for c, (i, j) in enumerate(full.carries):
        terms = [(streams[k], g[a], g[b]) for k, (a, b) in enumerate(full.carries) if k != c]
        H, _, _ = gyro_rotation_fit(B0, [], terms)
        cal = {"accel": accel.apply(laid.raw["accel"]), "gyro": (laid.raw["gyro"] - B0) @ H.T}
        out.append(carry_error_deg(laid, cal, full.poses[i].rows, full.poses[j].rows))
    return out


def imu_tk_method_poses(laid, full) -> dict[str, list[float]]:
    """imu_tk's accelerometer method held out, pose by pose: the pose's rows taken out of the record and the rest
    fitted as imu_tk fits (`turntable_free_accel`: its threshold sweep, upper-triangular H, the first 100 samples of
    each pose), then scored on the pose. On all poses it gives imu_tk's published Xsens figures (0.00811 and
    0.00112 m/s^2), so these are its method's held-out ones, where the published parameters can only be in-sample.
    None where the method cannot refit without a pose (the MPU-6050's ten poses leave nine, and it asks for ten)."""
    rest = initial_rest_s(laid)
    out = {"accel_pose_rms": [], "accel_pose_mean_error": []}
    for pose in full.poses:
        keep = np.ones(len(laid.t), bool)
        keep[pose.rows[0]:pose.rows[-1] + 1] = False
        try:
            accel = turntable_free_accel(laid.t[keep], laid.raw["accel"][keep], gravity=laid.gravity,
                                         init_static_s=rest)
        except CalibrationError:
            return {}
        rms, mean = pose_errors(accel.apply(laid.raw["accel"]), pose.rows, laid.gravity)
        out["accel_pose_rms"].append(rms)
        out["accel_pose_mean_error"].append(mean)
    return out


def imu_tk_method_heldout(laid, full) -> dict[str, list[float]]:
    return {"gyro_carry_deg": imu_tk_method_carries(laid, full), **imu_tk_method_poses(laid, full)}


def carry_split_deg(laid, full, cal: dict[str, np.ndarray]) -> dict | None:
    """RMS over the motions of the carried gravity's miss along each motion's angle direction and across it (deg)
    under a fixed calibration's series: the two parts the gyro fit weighs apart (`carry_weight`)."""
    if not full.carries or "gyro" not in cal:
        return None
    along, across = [], []
    for i, j in full.carries:
        a, b = full.poses[i], full.poses[j]
        g0, g1 = (np.nanmean(cal["accel"][p.rows], axis=0) for p in (a, b))
        g0, g1 = g0 / np.linalg.norm(g0), g1 / np.linalg.norm(g1)
        idx = np.arange(a.rows[-1], b.rows[0] + 1)
        w = cal["gyro"][idx]
        ok = ~np.isnan(w).any(axis=1)
        q = integrated_quats(np.eye(3), MoveSet.build([MoveStream(0, laid.t[idx][ok], w[ok], np.eye(3), np.eye(3))],
                                                      np.zeros(3)))
        angle = 2.0 * np.arctan2(np.linalg.norm(q[0, 1:]), q[0, 0])
        miss = axis_angle_matrix(q[0, 1:] / np.linalg.norm(q[0, 1:]), angle).T @ g0 - g1
        direction = angle_directions(q, g1[None])[0]
        along.append(float(miss @ direction))
        across.append(float(np.linalg.norm(miss - (miss @ direction) * direction)))
    rms = lambda v: float(np.degrees(np.sqrt(np.mean(np.square(v)))))     # noqa: E731
    return {"along_rms": rms(along), "across_rms": rms(across), "along_deg": np.degrees(along).round(3).tolist()}


def compare(name: str, session, peer: str, peer_series, peer_time_s: float, peer_heldout: set[str],
            peer_method_heldout=None) -> dict:
    """peer_heldout: the scores whose pieces the peer's fit never saw; peer_method_heldout(laid, full) -> {score:
    [errors]}: the peer's method refitted without each piece, where it can be."""
    t0 = time.perf_counter()
    refused = OURS(session).refused
    ours_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    held, inside = heldout_scores(session, OURS)
    held_s = time.perf_counter() - t0
    laid, full = scoring_layout(session)
    theirs = score_series(laid, full, peer_series(laid)).summary()
    ours_h, ours_in = held.summary(), inside.summary()
    rows = []
    for key, what in QUANTITY.items():
        o, p = ours_h[key]["rms"], theirs[key]["rms"]
        if o is None and p is None:
            continue
        peer_held = key in peer_heldout
        if key.startswith("gyro") and "gyro" in refused:      # `rig calibrate` writes no gyro: nothing to score
            rows.append({"quantity": what, "ours_heldout": None, "ours_in_sample": None, "ours_refused": refused["gyro"],
                         "peer": p, "peer_is": "in-sample (its fit saw this piece)", "ours_no_worse": None})
            continue
        rows.append({"quantity": what, "ours_heldout": o, "ours_in_sample": ours_in[key]["rms"],
                     "ours_n": f"{ours_h[key]['n']}/{ours_h[key]['of']}", "peer": p,
                     "peer_is": "held out" if peer_held else "in-sample (its fit saw this piece)",
                     "ours_no_worse": None if o is None or p is None else bool(o <= p)})
    if peer_method_heldout is not None:
        t0 = time.perf_counter()
        for key, errors in peer_method_heldout(laid, full).items():
            row = next(r for r in rows if r["quantity"].startswith(QUANTITY[key]))
            row["peer_method_heldout"] = float(np.sqrt(np.mean(np.square(errors))))
            if row["ours_heldout"] is not None:
                row["ours_no_worse_than_peer_method_heldout"] = bool(row["ours_heldout"] <= row["peer_method_heldout"])
        peer_time_s = peer_time_s, round(time.perf_counter() - t0, 2)
    split = {"ours_in_sample": carry_split_deg(laid, full, series(laid, full.sensors)),
             "peer": carry_split_deg(laid, full, peer_series(laid))}
    return {"recording": name, "rows_of_data": int(len(session.t)), "peer": peer, "comparison": rows,
            "ours_heldout": ours_h, "ours_in_sample": ours_in, "peer_scores": theirs, "notes": held.notes,
            "carry_miss_split_deg": split,
            "time_s": {"ours_calibrate": round(ours_s, 3), "ours_heldout_refits": round(held_s, 2),
                       "peer_calibrate": round(peer_time_s if isinstance(peer_time_s, float) else peer_time_s[0], 3),
                       **({} if isinstance(peer_time_s, float) else {"peer_method_heldout_refits": peer_time_s[1]})}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT / "tests" / "data")
    parser.add_argument("--only", default="si,raw,xsens,mpu,mikov")
    parser.add_argument("--mikov-repo", type=Path, help="a checkout of mikoff/imu-calib: all five of its logs")
    args = parser.parse_args()
    ferraris, xsens = args.data / "imucal-ferraris", args.data / "imu_tk-xsens"
    only, results = set(args.only.split(",")), []
    if "si" in only:
        csv, sections = ferraris / "example_ferraris_session.csv", ferraris / "example_ferraris_session_list.json"
        s = import_ferraris(rate_hz=102.4, units={"accel": "m/s^2", "gyro": "deg/s"}, csv=csv, sections=sections,
                            gravity=IMUCAL_GRAVITY)
        info, sec = imucal_ferraris(s, csv=csv, sections=sections, rate_hz=102.4, unit="m/s^2")
        results.append(compare("imucal-ferraris example_ferraris_session.csv (SI, 102.4 Hz)", s, "imucal 2.6.0",
                               lambda laid: imucal_series(info, laid), sec, IMUCAL_NEVER_FITS))
    if "raw" in only:
        annotated = ferraris / "annotated_session.csv"
        s = import_ferraris(rate_hz=204.8, units={}, annotated=annotated, gravity=IMUCAL_GRAVITY)
        info, sec = imucal_ferraris(s, annotated=annotated, rate_hz=204.8, unit="a.u.")
        results.append(compare("imucal-ferraris annotated_session.csv (counts, 204.8 Hz)", s, "imucal 2.6.0",
                               lambda laid: imucal_series(info, laid), sec, IMUCAL_NEVER_FITS))
    if "xsens" in only:
        s = import_imu_tk({"accel": xsens / "xsens_acc.mat", "gyro": xsens / "xsens_gyro.mat"}, gravity=XSENS_GRAVITY)
        results.append(compare("imu_tk-xsens (counts, 100 Hz)", s, "imu_tk (published parameters)",
                               lambda laid: published_series(IMU_TK_PUBLISHED, laid), IMU_TK_RUN_S, set(),
                               imu_tk_method_heldout))
    if "mpu" in only:
        mpu = ROOT / "tests" / "data" / "mpu6050-tomisuarez2"
        s = import_csv(mpu / "example_data_calibration.csv", {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"]},
                       units={"accel": "counts", "gyro": "counts"}, rate_hz=100.0, header_line=5, initial_rest_s=36.5)
        published = tomisuarez2_published(mpu)
        results.append(compare("tomisuarez2 MPU-6050 example_data_calibration.csv (counts, 100 Hz)", s,
                               "tomisuarez2/ImuCalibration (published parameters)",
                               lambda laid: published_series(published, laid), float("nan"), set(),
                               imu_tk_method_heldout))
    if "mikov" in only:
        logs = sorted((args.mikov_repo / "data").glob("imu*.log")) if args.mikov_repo else [MIKOV / "imu0.log"]
        peer = json.loads((MIKOV / "peer_params.json").read_text())
        for log in logs:
            s = import_csv(log, {"accel": ["1", "2", "3"], "gyro": ["4", "5", "6"]},
                           units={"accel": "m/s^2", "gyro": "rad/s"}, rate_hz=100.0, delimiter=" ", header_line=0,
                           initial_rest_s=7.0, gravity=MIKOV_GRAVITY)
            params = as_rig(peer[log.name])
            results.append(compare(f"mikoff/imu-calib MPU-9150 {log.name} (SI, 100 Hz)", s,
                                   "Mikov et al. (its own code, run here)",
                                   lambda laid, params=params: published_series(params, laid),
                                   peer[log.name]["seconds"], set(),
                                   lambda laid, full: {"gyro_carry_deg": imu_tk_method_carries(laid, full)}))
    print(json.dumps({"benchmark": "bench_recordings", "load": round(os.getloadavg()[0], 2), "recordings": results},
                     indent=1))


if __name__ == "__main__":
    main()
