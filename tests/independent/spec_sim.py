"""Independent simulator of `imu-session-csv/1` sessions, written only from the specs.

Why it exists: the project's own simulator and its calibration share one author's reading of the conventions,
so a convention error would cancel out. This file re-derives everything from `conventions.md` and
`session-csv.md` (two-axis tumble table R = Rx(outer) @ Rz(inner), fixture -> world; quaternions scalar-first
Hamilton; body rates in the fixture frame so that integrating them over a move gives R_j^T R_{j+1};
u = H (y - B)) and writes the truth in the `rig-calibration/1` layout, as an outside tester would.

Usage: python tests/independent/spec_sim.py OUT_DIR [--seed N] [--orientations 12|20] [--noise-free] ...
"""
from __future__ import annotations

import argparse
import csv
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

SENSOR_NAMES = ("accel", "gyro", "mag")
UNITS = {"accel": "m/s^2", "gyro": "rad/s", "mag": "uT"}

# Orientations (outer, inner) in degrees. Gravity in the fixture frame is G (sin a sin b, sin a cos b, cos a),
# so these cover the sphere; the outer axis seen from the fixture, (cos b, -sin b, 0), takes many directions.
ORIENTATIONS_20 = (
    (0, 0), (60, 0), (60, 90), (60, 180), (60, 270), (120, 270), (120, 180), (120, 90), (120, 0), (180, 0),
    (180, 120), (240, 120), (240, 30), (240, -60), (300, -60), (300, 30), (300, 120), (270, 45), (225, 135),
    (330, 200),
)
ORIENTATIONS_12 = (
    (0, 0), (90, 0), (90, 90), (90, 180), (90, 270), (180, 270), (180, 135), (270, 135), (270, 45),
    (270, -45), (45, -45), (135, 30),
)

# Nominal resolutions (fixture unit per count) of plausible parts: +-4 g accelerometer (8192 LSB/g),
# +-500 deg/s gyroscope (65.5 LSB/(deg/s)), 0.1 uT/LSB magnetometer.
NOMINAL_LSB = {"accel": 9.80665 / 8192.0, "gyro": math.radians(1.0) / 65.5, "mag": 0.1}
NOISE_LSB = {"accel": 0.8, "gyro": 3.0, "mag": 1.5}


@dataclass(frozen=True)
class TriadTruth:
    """True calibration of one sensor: u = H (y - B); raw noise sigma in counts."""

    H: np.ndarray
    B: np.ndarray
    noise_lsb: float


@dataclass(frozen=True)
class SessionSpec:
    """Everything that defines one simulated session."""

    seed: int = 1
    gravity_mps2: float = 9.80665
    field_uT: float = 48.0
    dip_deg: float = 62.0  # field points below the horizon (northern hemisphere)
    declination_deg: float = 23.0  # horizontal field direction measured from world x towards world y
    orientations: tuple[tuple[float, float], ...] = ORIENTATIONS_20
    hold_s: float = 5.0
    rate_hz: float = 100.0
    mag_every: int = 2  # magnetometer on every 2nd row: 50 Hz
    mag_phase: int = 0  # row index (mod mag_every) that carries the magnetometer sample
    sensors: tuple[str, ...] = SENSOR_NAMES
    noise_scale: float = 1.0
    lsb_scale: float = 1.0  # < 1: finer resolution (used for the noise-free session so rounding stays small)
    mean_move_rate_dps: float = 45.0
    move_profile: str = "cosine"  # or "trapezoid"
    settling: bool = False
    settle_ampl_deg: tuple[float, float] = (0.5, -0.3)  # ringing envelope scale of (outer, inner) at the start of each hold
    lever_arm_m: tuple[float, float, float] = (0.03, -0.02, 0.04)  # accelerometer position in the fixture frame
    mag_axes: str = "aligned"  # or "ak8963": mag x = fixture y, mag y = fixture x, mag z = -fixture z
    columns: dict[str, tuple[str, str, str]] = field(default_factory=lambda: {
        "accel": ("ax", "ay", "az"), "gyro": ("gx", "gy", "gz"), "mag": ("mx", "my", "mz")})
    t0_s: float = 0.0
    minimal: bool = False  # only the required meta keys and CSV columns (no table, rate, angles, temp_c)
    shuffle_columns: bool = False  # raw columns in the CSV in another order than meta.json lists them


# ---------------------------------------------------------------- rotations (own implementation, not rig's)

def rot_x(angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_z(angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def table_matrix(outer_rad: float, inner_rad: float) -> np.ndarray:
    """Fixture -> world matrix of the tumble table (conventions.md)."""
    return rot_x(outer_rad) @ rot_z(inner_rad)


def table_quaternion(outer_rad: float, inner_rad: float) -> np.ndarray:
    """q = qx(outer) (x) qz(inner), Hamilton product written out, scalar first, w >= 0."""
    ca, sa = math.cos(outer_rad / 2), math.sin(outer_rad / 2)
    cb, sb = math.cos(inner_rad / 2), math.sin(inner_rad / 2)
    q = np.array([ca * cb, sa * cb, -sa * sb, ca * sb])
    return -q if q[0] < 0 else q


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z) that maps v -> q v q*."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def body_rate(outer: float, inner: float, d_outer: float, d_inner: float) -> np.ndarray:
    """Fixture-frame rate w with dR/dt = R [w]x for R = Rx(a) Rz(b): w = a' Rz(b)^T e_x + b' e_z."""
    return np.array([d_outer * math.cos(inner), -d_outer * math.sin(inner), d_inner])


def body_rate_derivative(inner: float, d_outer: float, d_inner: float, dd_outer: float,
                         dd_inner: float) -> np.ndarray:
    return np.array([dd_outer * math.cos(inner) - d_outer * d_inner * math.sin(inner),
                     -dd_outer * math.sin(inner) - d_outer * d_inner * math.cos(inner), dd_inner])


# ---------------------------------------------------------------- motion profile

def _profile(kind: str, tau: float, duration: float) -> tuple[float, float, float]:
    """Fraction of the move done, and its first and second time derivatives, at tau in [0, duration]."""
    x = tau / duration
    if kind == "cosine":
        return ((1 - math.cos(math.pi * x)) / 2, math.pi / (2 * duration) * math.sin(math.pi * x),
                math.pi ** 2 / (2 * duration ** 2) * math.cos(math.pi * x))
    if kind == "trapezoid":  # accelerate over the first quarter, cruise, decelerate over the last quarter
        acc = 1.0 / (0.75 * 0.25 * duration ** 2)
        ta = 0.25 * duration
        if tau < ta:
            return 0.5 * acc * tau ** 2, acc * tau, acc
        if tau <= duration - ta:
            return 0.5 * acc * ta ** 2 + acc * ta * (tau - ta), acc * ta, 0.0
        rest = duration - tau
        return 1 - 0.5 * acc * rest ** 2, acc * rest, -acc
    raise ValueError(f"unknown move profile {kind!r}")


@dataclass(frozen=True)
class Segment:
    phase: str
    step: int
    start: float
    end: float
    start_deg: tuple[float, float]
    end_deg: tuple[float, float]


def build_timeline(spec: SessionSpec, rng: np.random.Generator) -> list[Segment]:
    """Holds of hold_s (plus a sub-sample jitter so moves do not start on a sample) and moves between them."""
    segments: list[Segment] = []
    t = spec.t0_s
    orient = spec.orientations
    for j, here in enumerate(orient):
        hold_len = spec.hold_s + float(rng.uniform(0.001, 0.009))
        segments.append(Segment("hold", j, t, t + hold_len, here, here))
        t += hold_len
        if j + 1 < len(orient):
            there = orient[j + 1]
            span = max(abs(there[0] - here[0]), abs(there[1] - here[1]))
            duration = max(1.0, span / spec.mean_move_rate_dps)
            segments.append(Segment("move", j, t, t + duration, here, there))
            t += duration
    return segments


@dataclass
class TableState:
    angles_rad: np.ndarray  # (outer, inner)
    rates: np.ndarray
    accels: np.ndarray


SETTLE_HZ = 4.0
SETTLE_TAU_S = (0.12, 0.03)  # slow decay, fast rise of the ringing envelope


def settling_offset(tau: float, ampl_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ringing d(tau) = A (e^{-tau/T1} - e^{-tau/T2}) sin(w tau) and its first two derivatives.

    Angle and rate are continuous at the stop (d(0) = d'(0) = 0, as for a real axis) and d -> 0, so
    the net rotation over a hold is zero.
    """
    w = 2 * math.pi * SETTLE_HZ
    k1, k2 = 1 / SETTLE_TAU_S[0], 1 / SETTLE_TAU_S[1]
    e1, e2 = math.exp(-k1 * tau), math.exp(-k2 * tau)
    f, df, ddf = e1 - e2, -k1 * e1 + k2 * e2, k1 * k1 * e1 - k2 * k2 * e2
    s, c = math.sin(w * tau), math.cos(w * tau)
    return (ampl_rad * f * s, ampl_rad * (df * s + f * w * c),
            ampl_rad * (ddf * s + 2 * df * w * c - f * w * w * s))


def table_state(seg: Segment, t: float, spec: SessionSpec) -> TableState:
    a0 = np.radians(seg.start_deg)
    if seg.phase == "move":
        delta = np.radians(seg.end_deg) - a0
        f, df, ddf = _profile(spec.move_profile, t - seg.start, seg.end - seg.start)
        return TableState(a0 + f * delta, df * delta, ddf * delta)
    angles, rates, accels = a0.copy(), np.zeros(2), np.zeros(2)
    if spec.settling and seg.step > 0:
        d, dd, ddd = settling_offset(t - seg.start, np.radians(spec.settle_ampl_deg))
        angles, rates, accels = angles + d, rates + dd, accels + ddd
    return TableState(angles, rates, accels)


# ---------------------------------------------------------------- truth

def world_field(spec: SessionSpec) -> np.ndarray:
    dip, dec = math.radians(spec.dip_deg), math.radians(spec.declination_deg)
    return spec.field_uT * np.array([math.cos(dip) * math.cos(dec), math.cos(dip) * math.sin(dec), -math.sin(dip)])


def _off_diagonal_misalignment(rng: np.random.Generator, size: float) -> np.ndarray:
    e = rng.normal(0.0, size, (3, 3))
    np.fill_diagonal(e, 0.0)
    return e


def make_truth(spec: SessionSpec, rng: np.random.Generator) -> dict[str, TriadTruth]:
    """Scale errors of several %, ~1 % misalignment, soft iron on the magnetometer; det(H) > 0."""
    bias_counts = {"accel": 250.0, "gyro": 150.0, "mag": 150.0}
    truth: dict[str, TriadTruth] = {}
    for name in spec.sensors:
        scale = np.diag(1.0 + rng.uniform(-0.06, 0.06, 3))
        mis = np.eye(3) + _off_diagonal_misalignment(rng, 0.01)
        H = NOMINAL_LSB[name] * spec.lsb_scale * scale @ mis
        if name == "mag":
            soft = rng.normal(0.0, 0.03, (3, 3))
            H = (np.eye(3) + (soft + soft.T) / 2) @ H
            if spec.mag_axes == "ak8963":
                # columns of H: sensor x reads fixture y, sensor y reads fixture x, sensor z reads -fixture z
                H = H @ np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
        assert np.linalg.det(H) > 0
        B = rng.uniform(-1.0, 1.0, 3) * bias_counts[name] / spec.lsb_scale
        truth[name] = TriadTruth(H, B, NOISE_LSB[name] * spec.noise_scale)
    return truth


# ---------------------------------------------------------------- sampling

@dataclass
class SimulatedSession:
    spec: SessionSpec
    truth: dict[str, TriadTruth]
    times: np.ndarray
    phases: list[str]
    steps: np.ndarray
    quats: np.ndarray
    angles_deg: np.ndarray
    raw: dict[str, np.ndarray]  # float arrays, NaN where the sensor has no sample
    true_input: dict[str, np.ndarray]  # fixture-frame inputs u


def simulate(spec: SessionSpec) -> SimulatedSession:
    rng = np.random.default_rng(spec.seed)
    truth = make_truth(spec, rng)
    segments = build_timeline(spec, rng)
    dt = 1.0 / spec.rate_hz
    n = int(math.floor((segments[-1].end - spec.t0_s) / dt))
    times = spec.t0_s + dt * np.arange(n)
    m_world = world_field(spec)
    g_up = np.array([0.0, 0.0, spec.gravity_mps2])
    lever = np.array(spec.lever_arm_m)
    phases: list[str] = []
    steps = np.zeros(n, dtype=int)
    quats = np.zeros((n, 4))
    angles = np.zeros((n, 2))
    inputs = {name: np.zeros((n, 3)) for name in SENSOR_NAMES}
    rate_dot = np.zeros((n, 3))
    seg_i = 0
    for k, t in enumerate(times):
        while t >= segments[seg_i].end and seg_i + 1 < len(segments):
            seg_i += 1
        seg = segments[seg_i]
        st = table_state(seg, t, spec)
        a, b = st.angles_rad
        R = table_matrix(a, b)
        w = body_rate(a, b, *st.rates)
        rate_dot[k] = body_rate_derivative(b, st.rates[0], st.rates[1], st.accels[0], st.accels[1])
        phases.append(seg.phase)
        steps[k] = seg.step
        quats[k] = table_quaternion(a, b)
        angles[k] = np.degrees(st.angles_rad)
        inputs["accel"][k] = R.T @ g_up
        inputs["gyro"][k] = w
        inputs["mag"][k] = R.T @ m_world
    w = inputs["gyro"]
    inputs["accel"] += np.cross(rate_dot, lever) + np.cross(w, np.cross(w, lever))  # lever arm: a = w' x r + w x (w x r)
    raw: dict[str, np.ndarray] = {}
    for name in spec.sensors:
        tr = truth[name]
        y = inputs[name] @ np.linalg.inv(tr.H).T + tr.B + rng.normal(0.0, 1.0, (n, 3)) * tr.noise_lsb
        y = np.round(y)
        if name == "mag":
            y[np.arange(n) % spec.mag_every != spec.mag_phase] = np.nan
        raw[name] = y
    return SimulatedSession(spec, truth, times, phases, steps, quats, angles, raw, inputs)


# ---------------------------------------------------------------- writing

def write_session(sim: SimulatedSession, out_dir: Path) -> Path:
    """meta.json + samples.csv per session-csv.md, and truth.json in the rig-calibration/1 layout."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    spec = sim.spec
    meta = {
        "format": "imu-session-csv/1",
        "gravity_mps2": spec.gravity_mps2,
        "sample_rate_hz": spec.rate_hz,
        "sensors": {name: list(spec.columns[name]) for name in spec.sensors},
        "table": {"outer_axis_world": [1, 0, 0], "inner_axis_fixture": [0, 0, 1]},
        "generator": {"name": "tests/independent/spec_sim.py", "seed": spec.seed},
    }
    if "mag" in spec.sensors:
        meta["field_uT"] = spec.field_uT
    if spec.minimal:
        meta = {k: meta[k] for k in ("format", "gravity_mps2", "field_uT", "sensors") if k in meta}
    (out_dir / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    header = ["t", "phase", "step", "qw", "qx", "qy", "qz"]
    if not spec.minimal:
        header += ["table_outer_deg", "table_inner_deg"]
    raw_columns = [(name, axis) for name in spec.sensors for axis in range(3)]
    if spec.shuffle_columns:
        raw_columns = raw_columns[::-1]
    header += [spec.columns[name][axis] for name, axis in raw_columns]
    if not spec.minimal:
        header.append("temp_c")
    with open(out_dir / "samples.csv", "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for k in range(len(sim.times)):
            row = [f"{sim.times[k]:.4f}", sim.phases[k], str(sim.steps[k])]
            row += [f"{v:.10f}" for v in sim.quats[k]]
            if not spec.minimal:
                row += [f"{v:.5f}" for v in sim.angles_deg[k]]
            for name, axis in raw_columns:
                v = sim.raw[name][k, axis]
                row.append("" if math.isnan(v) else str(int(v)))
            if not spec.minimal:
                row.append(f"{25.0 + 0.001 * k / spec.rate_hz:.3f}")
            writer.writerow(row)
    (out_dir / "truth.json").write_text(json.dumps(truth_document(sim), indent=2) + "\n")
    return out_dir


def truth_document(sim: SimulatedSession) -> dict:
    doc = {"schema": "rig-calibration/1", "software": "spec_sim (independent)",
           "gravity_mps2": sim.spec.gravity_mps2, "sensors": {}}
    if "mag" in sim.spec.sensors:
        doc["field_uT"] = sim.spec.field_uT
    for name, tr in sim.truth.items():
        doc["sensors"][name] = {"unit": UNITS[name], "B": tr.B.tolist(), "H": tr.H.tolist(),
                                "noise_lsb": tr.noise_lsb}
    return doc


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out_dir", type=Path)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--orientations", type=int, choices=(12, 20), default=20)
    p.add_argument("--gravity", type=float, default=9.80665)
    p.add_argument("--noise-free", action="store_true")
    p.add_argument("--settling", action="store_true")
    p.add_argument("--settle-amplitude", type=float, default=0.5,
                   help="ringing envelope scale of the outer axis, deg (inner: -0.6 x); peak ~0.47 x this")
    p.add_argument("--no-mag", action="store_true")
    p.add_argument("--profile", choices=("cosine", "trapezoid"), default="cosine")
    p.add_argument("--mag-axes", choices=("aligned", "ak8963"), default="aligned")
    args = p.parse_args(argv)
    spec = SessionSpec(seed=args.seed, gravity_mps2=args.gravity, settling=args.settling,
                       settle_ampl_deg=(args.settle_amplitude, -0.6 * args.settle_amplitude),
                       orientations=ORIENTATIONS_12 if args.orientations == 12 else ORIENTATIONS_20,
                       move_profile=args.profile, mag_axes=args.mag_axes)
    if args.noise_free:
        spec = replace(spec, noise_scale=0.0, lsb_scale=1 / 64)
    if args.no_mag:
        spec = replace(spec, sensors=("accel", "gyro"))
    write_session(simulate(spec), args.out_dir)


if __name__ == "__main__":
    main()
