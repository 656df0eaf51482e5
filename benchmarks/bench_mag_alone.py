"""Benchmark: a magnetometer alone (`rig.calibration.recordings.mag_alone`) on simulated hand tumbles, how honest its
stated deviations are and how long a fit takes; and, with --accel-mag, the dip of an accelerometer beside it.

Each seed is one minute of tumbling at 50 Hz (3000 samples; tests/recordings/tumble_synth.py) of `mag_synth`'s
sensor (48 uT dipping 60 deg, hard iron up to 40 uT, soft iron a few %, 0.3 uT of noise). Printed: the RMS over
the seeds of the errors of B, of H's diagonal and of its off-diagonal entries in their stated deviations (1 where
the deviations are honest), with the local field given and without it (then also the field magnitude's), and
the median seconds of one fit. --accel-mag: the dip's RMS z over `test_magnetometer_recordings.hand_session`
recordings without their gyro (20 poses found in the data; about 3 s each).

Usage: python benchmarks/bench_mag_alone.py [--seeds 100] [--accel-mag 40]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "recordings"))

from mag_synth import INCLINATION_DEG, mag_truth, readings  # noqa: E402
from test_magnetometer_recordings import hand_session  # noqa: E402
from tumble_synth import tumble  # noqa: E402

from rig.calibration.recordings.mag_alone import calibrate_mag_alone  # noqa: E402
from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.calibration.numerics.threads import one_blas_thread  # noqa: E402
from rig.io.recording import recording_session  # noqa: E402


def symmetric(H: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(H.T @ H)
    return (V * np.sqrt(w)) @ V.T


def rms(values) -> float:
    return round(float(np.sqrt(np.mean(np.square(values)))), 3)


def alone(seeds: int, given: bool) -> dict:
    zB, diagonal, off, field, seconds = [], [], [], [], []
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        t, R = tumble(rng)
        truth = mag_truth(rng)
        y = readings(R, truth, rng)
        start = time.perf_counter()
        cal, _ = calibrate_mag_alone(y, truth.field_uT if given else None, source="bench", raw_unit="uT")
        seconds.append(time.perf_counter() - start)
        P = symmetric(truth.H)
        if not given:
            k = np.linalg.det(P) ** (-1.0 / 3.0)
            P = P * k
            field.append((cal.extra["field_magnitude"] - truth.field_uT * k) / cal.extra["field_magnitude_std"])
        h = (cal.H - P) / cal.H_std
        zB += list((cal.B - truth.B) / cal.B_std)
        diagonal += list(np.diag(h))
        off += list(h[np.triu_indices(3, 1)])
    out = {"seeds": seeds, "rms_z_B": rms(zB), "rms_z_H_diagonal": rms(diagonal), "rms_z_H_off_diagonal": rms(off),
           "median_fit_s": round(float(np.median(seconds)), 3)}
    if field:
        out["rms_z_field_magnitude"] = rms(field)
    return out


def accel_mag(seeds: int) -> dict:
    z = []
    for seed in range(seeds):
        rec, truth, mag = hand_session(seed)
        session = recording_session(rec["t"], {"accel": rec["accel"], "mag": mag},
                                    units={"accel": "m/s^2", "mag": "uT"}, source="bench", gravity=9.81,
                                    field_uT=truth.field_uT, sample_rate_hz=50.0)
        with one_blas_thread():
            m = calibrate_recording(session).sensors["mag"]
        z.append((m.extra["dip_deg"] - INCLINATION_DEG) / m.extra["dip_std_deg"])
    return {"seeds": seeds, "rms_z_dip": rms(z), "max_abs_z_dip": round(float(np.abs(z).max()), 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--accel-mag", type=int, default=0, help="recordings for the dip (0: skip)")
    args = parser.parse_args()
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    result = {"benchmark": "bench_mag_alone", "date": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
              "commit": commit, "machine": f"{platform.machine()} {os.cpu_count()} cpus {platform.python_version()}",
              "load": round(os.getloadavg()[0], 2),
              "field_given": alone(args.seeds, True), "field_from_data": alone(args.seeds, False)}
    if args.accel_mag:
        result["accel_mag"] = accel_mag(args.accel_mag)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
