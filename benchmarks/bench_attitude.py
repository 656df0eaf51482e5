"""Benchmark: the quaternion UKF's throughput on one core (target >= 20 000 samples/s), and the
filterpy-based reference it is checked against, on a synthetic 100 Hz record (accel/gyro every row,
magnetometer every other row). Both magnetometer modes. Also `rig validate --sim` end to end, and the
Table III totals over five simulated units (seeds 0-4).

Prints JSON. samples/s counts every input row (time update on each; gravity update on each; field or
heading update on every other); the figure includes the vectorised preparation.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rig.attitude.reference import estimate_attitude_filterpy  # noqa: E402
from rig.attitude.ukf import UKFSettings, estimate_attitude  # noqa: E402


def synthetic(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    dt = 0.01
    t = np.arange(n) * dt
    w = np.column_stack([0.8 * np.sin(0.7 * t), 1.2 * np.sin(0.5 * t + 0.3), 0.6 * np.cos(0.9 * t)])
    w[:100] = 0.0
    steps = Rotation.from_rotvec(0.5 * (w[1:] + w[:-1]) * dt)
    R = [Rotation.identity()]
    for s in steps:
        R.append(R[-1] * s)
    R = Rotation.concatenate(R).as_matrix()
    dip = math.radians(60.0)
    m_nav = 50.0 * np.array([0.0, math.cos(dip), -math.sin(dip)])
    acc = np.einsum("nji,j->ni", R, [0.0, 0.0, 9.80665]) + rng.normal(0, 0.012, (n, 3))
    mag = np.einsum("nji,j->ni", R, m_nav) + rng.normal(0, 0.15, (n, 3))
    mag[1::2] = np.nan
    return t, w + rng.normal(0, 0.004, (n, 3)), acc, mag


def rate(fn, n: int, repeats: int) -> dict:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return {"samples": n, "best_s": min(times), "median_s": float(np.median(times)),
            "samples_per_s_best": n / min(times), "samples_per_s_median": n / float(np.median(times))}


def main() -> None:
    n = 60_000
    t, gyro, acc, mag = synthetic(n)
    out = {"python": sys.version.split()[0], "record": f"{n} rows at 100 Hz, mag every other row"}
    for mode in ("vector", "heading"):
        s = UKFSettings(mag_measurement=mode)
        out[f"ukf_{mode}"] = rate(lambda: estimate_attitude(t, gyro, acc, mag, field_uT=50.0, settings=s), n, 5)
        m = 2000
        out[f"filterpy_reference_{mode}"] = rate(
            lambda: estimate_attitude_filterpy(t[:m], gyro[:m], acc[:m], mag[:m], field_uT=50.0, settings=s), m, 1)
        fast = estimate_attitude(t[:m], gyro[:m], acc[:m], mag[:m], field_uT=50.0, settings=s)
        ref = estimate_attitude_filterpy(t[:m], gyro[:m], acc[:m], mag[:m], field_uT=50.0, settings=s)
        out[f"max_abs_quaternion_difference_vs_filterpy_{mode}"] = float(np.abs(fast.q - ref.q).max())
    from click.testing import CliRunner

    from rig.commands.attitude import validate

    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        res = CliRunner().invoke(validate, ["--sim", "--seed", "0", "--out", d])
        wall = time.perf_counter() - t0
        doc = json.loads((Path(d) / "validation.json").read_text()) if res.exit_code == 0 else {}
    out["rig_validate_sim"] = {"exit_code": res.exit_code, "wall_s": wall, "rms_deg_ours": doc.get("rms_deg"),
                               "table_rms_deg": {r["label"]: r["rms_deg"] for r in doc.get("table", [])}}
    out["over_seeds"] = over_seeds(range(5))
    print(json.dumps(out, indent=2))


def over_seeds(seeds) -> dict:
    """Table III per seed on the simulated rig (each seed: its own unit, calibration and trajectory):
    per estimator the total RMS sqrt(roll^2 + pitch^2 + yaw^2), its mean over seeds, and how often the
    UKF with our calibration beat it."""
    from procedures.validation import validate_on_rig
    from rig.config import load_config

    totals: dict[str, list[float]] = {}
    for seed in seeds:
        with tempfile.TemporaryDirectory() as d, contextlib.redirect_stdout(io.StringIO()):
            result, _ = validate_on_rig(Path(d), load_config(), sim=True, seed=seed, plots=False, echo=lambda *_: None)
        for r in result.rows:
            key = r.filter if r.filter != "ukf" else f"ukf, {r.calibration.split(' (')[0]}"
            totals.setdefault(key, []).append(float(np.sqrt(sum(v * v for v in r.comparison.rms().values()))))
    ours = np.array(totals["ukf, ours"])
    return {k: {"total_rms_deg": [round(x, 4) for x in v], "mean": float(np.mean(v)),
                "ours_better_in": f"{int(np.sum(ours < np.array(v)))}/{len(v)}"} for k, v in totals.items()}


if __name__ == "__main__":
    main()
