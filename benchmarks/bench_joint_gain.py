"""How much more accurate the joint estimator is than the two-step method, and how much more any unbiased
estimator could be (Cramer-Rao bound); prints JSON.

Target: "with 12 orientations, the joint estimator at least 3 times more accurate than the two-step
method". Accuracy is not one number, so every statistic is printed and none is picked: for each trial the B
error |dB|, the relative H error ||dH||_F / ||H||_F and the calibrated-vector error (RMS over 2000 directions of
|H_est (y - B_est) - u| / |u|, what a user of the calibration sees), then the gain two-step / joint as the
ratio of RMS errors (the usual "accuracy" of a Monte Carlo, with a 95 % bootstrap interval over trials: the
RMS is dominated by a few trials), of mean errors and of median errors.

The bound (rig.calibration.turntable.bounds) of each trial's schedule gives the smallest mean-square error an unbiased
estimator can have there; over random schedules the bound of the RMS is sqrt(mean over trials of the
per-schedule trace). joint_over_crb near 1 means the joint estimator cannot be improved; two_step_over_crb
is the largest RMS gain over two-step that any unbiased estimator could show.

Setups: the paper's Table I Monte Carlo (reconstructed truth, noise variance 0.1 counts^2) with 12 random
orientations, the same with 12 planned orientations (a Fibonacci sphere with a random azimuth, as `rig plan`
makes), 20 random orientations for contrast, 12 random orientations the tumble table can reach (uniform
reference directions, one yaw for all holds: unlike "random", the holds do not each add a known turn about the
reference, so the reference direction is harder to tell from H); a noise sweep and an orientation sweep (random
schedules, each point an independent seed, so the 12-orientation, 0.1 counts^2 point replicates the first case); and,
for the first case, where the heavy tail comes from (trials binned by the spread of the reference directions).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from procedures.paper_table1 import B_A, H_A, NOISE_VARIANCE  # noqa: E402
from rig.units import STANDARD_GRAVITY as G  # noqa: E402
from rig.schedule import plan_orientations, schedule_rotations  # noqa: E402
from rig.calibration.turntable.bounds import cramer_rao  # noqa: E402
from rig.calibration.turntable.joint import calibrate_joint  # noqa: E402
from rig.calibration.turntable.twostep import calibrate_two_step  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402
from rig.rotations import TableGeometry  # noqa: E402

TRIALS = 1000
NOISE_SWEEP = (0.01, 0.1, 1.0, 10.0, 100.0)     # counts^2 on each raw hold mean
ORIENTATION_SWEEP = (6, 9, 12, 20)
BOOTSTRAP = 2000
FIGURES = ("B", "H", "vector")
REFERENCE = np.array([0.0, 0.0, G])


def _directions(rng: np.random.Generator, n: int = 2000) -> np.ndarray:
    d = rng.standard_normal((n, 3))
    return G * d / np.linalg.norm(d, axis=1, keepdims=True)


def _errors(cal, U: np.ndarray, Y: np.ndarray) -> tuple[float, float, float]:
    vec = np.sqrt(np.mean(np.sum(((Y - cal.B) @ cal.H.T - U) ** 2, axis=1))) / G
    return float(np.linalg.norm(cal.B - B_A)), float(np.linalg.norm(cal.H - H_A) / np.linalg.norm(H_A)), float(vec)


def _rotations(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    if kind == "random":
        return Rotation.random(n, random_state=rng).as_matrix()
    yaw = Rotation.from_euler("z", rng.uniform(0, 360), degrees=True).as_matrix()
    if kind == "table_random":           # uniform reference directions, reachable by the tumble table
        outer = np.degrees(np.arccos(1 - 2 * rng.uniform(size=n)))
        return yaw @ TableGeometry().rotation(outer, rng.uniform(-180, 180, n))
    return yaw @ schedule_rotations(plan_orientations(n, seed=int(rng.integers(1 << 31))))


def _centred_spread(R: np.ndarray) -> float:
    """Smallest singular value of the centred unit reference directions (sqrt of the smallest eigenvalue
    of their covariance): small when the directions bunch on a cap or a cone, where the ellipsoid is weak."""
    x = np.einsum("kji,j->ki", R, REFERENCE) / G
    x = x - x.mean(axis=0)
    return float(np.sqrt(max(np.linalg.eigvalsh(x.T @ x / len(x))[0], 0.0)))


def _trials(kind: str, n: int, trials: int, seed: int, noise_variance: float) -> dict:
    """Per-trial errors (NaN where a method refused), bound and geometry. The random draws are in the same
    order as before the bound was added, so the three main cases reproduce the earlier figures."""
    rng = np.random.default_rng(seed)
    U = _directions(rng)
    Y = U @ np.linalg.inv(H_A).T + B_A
    sigma = np.sqrt(noise_variance)
    two, joint, crb = (np.full((trials, 3), np.nan) for _ in range(3))
    spread = np.empty(trials)
    for t in range(trials):
        R = _rotations(kind, n, rng)
        y = np.einsum("kji,j->ki", R, REFERENCE) @ np.linalg.inv(H_A).T + B_A
        y += sigma * rng.standard_normal(y.shape)
        spread[t] = _centred_spread(R)
        try:
            bound = cramer_rao(R, H_A, B_A, REFERENCE, sigma)
            crb[t] = bound.B_rms, bound.H_rel_rms, bound.vector_rel_rms
        except CalibrationError:
            pass
        try:
            two[t] = _errors(calibrate_two_step(y, R, G), U, Y)
        except CalibrationError:
            pass
        try:
            joint[t] = _errors(calibrate_joint(y, R, G, y_std=np.full(y.shape, sigma)), U, Y)
        except CalibrationError:
            pass
    return {"two": two, "joint": joint, "crb": crb, "spread": spread}


def _rms(a: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(a**2, axis=0))


def _fig(values) -> dict | None:
    return None if values is None else {k: round(float(x), 3) for k, x in zip(FIGURES, values)}


def _abs_fig(values) -> dict:
    return {"B_counts": float(values[0]), "H_rel": float(values[1]), "vector_rel": float(values[2])}


def _bootstrap_ratio(num: np.ndarray, den: np.ndarray, rng: np.random.Generator) -> dict:
    """95 % interval of the ratio of RMS figures, resampling trials."""
    idx = rng.integers(0, len(num), (BOOTSTRAP, len(num)))
    g = np.sqrt(np.mean(num[idx] ** 2, axis=1) / np.mean(den[idx] ** 2, axis=1))
    lo, hi = np.quantile(g, [0.025, 0.975], axis=0)
    return {k: [round(float(a), 2), round(float(b), 2)] for k, a, b in zip(FIGURES, lo, hi)}


def summarise(kind: str, n: int, noise_variance: float, seed: int, d: dict) -> dict:
    two, joint, crb = d["two"], d["joint"], d["crb"]
    ok_two, ok_joint, ok_crb = (np.isfinite(a).all(axis=1) for a in (two, joint, crb))
    out = {"orientations": n, "schedule": kind, "noise_variance_counts2": noise_variance, "seed": seed,
           "trials": int(len(two)),
           "refused": {"two_step": int((~ok_two).sum()), "joint": int((~ok_joint).sum()),
                       "crb_infinite": int((~ok_crb).sum())}}
    both = ok_two & ok_joint & ok_crb
    out["compared_trials"] = int(both.sum())
    if both.any():
        t, j = two[both], joint[both]
        for stat, f in (("rms", _rms), ("mean", lambda a: a.mean(axis=0)), ("median", lambda a: np.median(a, axis=0))):
            out[f"gain_{stat}"] = _fig(f(t) / f(j))
        out["gain_rms_95pct"] = _bootstrap_ratio(t, j, np.random.default_rng(seed))
        out["share_of_trials_joint_3x_better_vector"] = round(float(np.mean(t[:, 2] >= 3 * j[:, 2])), 3)
    else:
        out["gain_rms"] = out["gain_mean"] = out["gain_median"] = None
        out["gain_note"] = "two-step refused every trial (it needs >= 9 distinct orientations)"
    for name, err, ok in (("two_step", two, ok_two), ("joint", joint, ok_joint)):
        sel = ok & ok_crb
        out[f"{name}_rms"] = _abs_fig(_rms(err[sel])) if sel.any() else None
        out[f"{name}_over_crb"] = _fig(_rms(err[sel]) / _rms(crb[sel])) if sel.any() else None
    sel = ok_joint & ok_crb
    if sel.any():
        out["joint_over_crb_95pct"] = _bootstrap_ratio(joint[sel], crb[sel], np.random.default_rng(seed + 1))
        out["joint_trials_over_5x_crb"] = {k: int(c) for k, c in zip(FIGURES, (joint[sel] > 5 * crb[sel]).sum(axis=0))}
    out["crb_rms"] = _abs_fig(_rms(crb[ok_crb])) if ok_crb.any() else None
    return out


def tail(d: dict) -> dict:
    """Where the RMS comes from: share of the mean-square error in the worst 10 % of trials, and RMS errors
    per decile/quartile bin of the centred direction spread."""
    ok = np.isfinite(d["two"]).all(axis=1) & np.isfinite(d["joint"]).all(axis=1) & np.isfinite(d["crb"]).all(axis=1)
    two, joint, crb, s = d["two"][ok], d["joint"][ok], d["crb"][ok], d["spread"][ok]

    def worst_share(a):
        e = np.sort(a**2, axis=0)[::-1]
        return _fig(e[: max(1, len(e) // 10)].sum(axis=0) / e.sum(axis=0))

    edges = np.quantile(s, [0.0, 0.1, 0.25, 0.5, 0.75, 1.0])
    bins = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (s >= lo) & (s <= hi)
        bins.append({"spread_range": [round(float(lo), 3), round(float(hi), 3)], "trials": int(m.sum()),
                     "two_step_rms": _abs_fig(_rms(two[m])), "joint_rms": _abs_fig(_rms(joint[m])),
                     "crb_rms": _abs_fig(_rms(crb[m])), "gain_rms": _fig(_rms(two[m]) / _rms(joint[m])),
                     "two_step_over_crb": _fig(_rms(two[m]) / _rms(crb[m]))})
    return {"spread_kind": "smallest singular value of the centred unit reference directions in the fixture frame "
                           "(0 = all on a cone/cap, 0.577 = ideal)",
            "mse_share_of_worst_10pct_trials": {"two_step": worst_share(two), "joint": worst_share(joint),
                                                "crb": worst_share(crb)},
            "bins_by_spread": bins}


def main() -> None:
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else TRIALS
    t0 = time.perf_counter()
    main_cases = [("random", 12, NOISE_VARIANCE, 0), ("planned", 12, NOISE_VARIANCE, 1), ("random", 20, NOISE_VARIANCE, 2),
                  ("table_random", 12, NOISE_VARIANCE, 3)]
    cases, first = [], None
    for kind, n, var, seed in main_cases:
        d = _trials(kind, n, trials, seed, var)
        first = d if first is None else first
        cases.append(summarise(kind, n, var, seed, d))
    noise = [summarise("random", 12, var, 10 + i, _trials("random", 12, trials, 10 + i, var))
             for i, var in enumerate(NOISE_SWEEP)]
    orient = [summarise("random", n, NOISE_VARIANCE, 20 + i, _trials("random", n, trials, 20 + i, NOISE_VARIANCE))
              for i, n in enumerate(ORIENTATION_SWEEP)]
    print(json.dumps({"target": "joint >= 3x more accurate than two-step with 12 orientations",
                      "noise_variance_counts2": NOISE_VARIANCE, "trials_per_case": trials,
                      "cases": cases, "tail_12_random": tail(first),
                      "noise_sweep_12_random": noise, "orientation_sweep": orient,
                      "seconds": round(time.perf_counter() - t0, 1)}, indent=1))


if __name__ == "__main__":
    main()
