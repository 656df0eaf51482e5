"""A second spec-only session simulator that deliberately makes different choices than ours.

Written from conventions.md, session-csv.md and calibration-json.md only (it never imports `rig`),
so that `rig calibrate --from` is tested against choices the spec allows but our own code did not make:
other sample rates, filtered gyro samples, multi-rate rows, an optical-tracker reference, jittered or
Unix timestamps, strong mounting rotations, lever arms and settling.

Usage: python tests/independent_vary/vary_sim.py OUT --seed N [--variant NAME] [--schedule FILE.json]

`--schedule` (or `generate(..., schedule=Schedule(...))`) replaces the random orientations, hold lengths and
move limits by a plan given from outside, so that one plan can be run here and on the rig (the
planner's plan against today's default). The unit, its noise and everything else stay the variant's.
"""
from __future__ import annotations

import argparse
import json
import subprocess
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import signal

DEG = np.pi / 180.0
INT16 = (-32768, 32767)


# ---------------------------------------------------------------- rotations (tested against scipy)
def rot_x(a: np.ndarray | float) -> np.ndarray:
    """Rotation matrices about x for angles `a` in rad; shape (..., 3, 3)."""
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_z(b: np.ndarray | float) -> np.ndarray:
    """Rotation matrices about z for angles `b` in rad; shape (..., 3, 3)."""
    b = np.asarray(b, float)
    c, s = np.cos(b), np.sin(b)
    o, z = np.ones_like(b), np.zeros_like(b)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def table_quat(outer_rad: np.ndarray, inner_rad: np.ndarray) -> np.ndarray:
    """Scalar-first quaternion of R = Rx(outer) @ Rz(inner), built as the Hamilton product qx * qz
    (not via a matrix), so that the scipy check is an independent one."""
    ha, hb = np.asarray(outer_rad) / 2, np.asarray(inner_rad) / 2
    ca, sa, cb, sb = np.cos(ha), np.sin(ha), np.cos(hb), np.sin(hb)
    return np.stack([ca * cb, sa * cb, -sa * sb, ca * sb], -1)


def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product of scalar-first quaternions."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], -1)


def quat_exp(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternion of a rotation vector (rad)."""
    ang = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    axis = np.divide(rotvec, ang, out=np.zeros_like(rotvec), where=ang > 0)
    return np.concatenate([np.cos(ang / 2), np.sin(ang / 2) * axis], -1)


def body_rate(outer_rate: np.ndarray, inner_rad: np.ndarray, inner_rate: np.ndarray) -> np.ndarray:
    """Fixture-frame angular rate of R = Rx(a) Rz(b): R^T dR/dt = [a' Rz(b)^T e_x + b' e_z]x."""
    return np.stack([outer_rate * np.cos(inner_rad), -outer_rate * np.sin(inner_rad), inner_rate], -1)


def body_accel(outer_rate, outer_acc, inner_rad, inner_rate, inner_acc) -> np.ndarray:
    """Time derivative of `body_rate` (the fixture-frame angular acceleration)."""
    c, s = np.cos(inner_rad), np.sin(inner_rad)
    return np.stack([outer_acc * c - outer_rate * inner_rate * s,
                     -outer_acc * s - outer_rate * inner_rate * c, inner_acc], -1)


# ---------------------------------------------------------------- motion
@dataclass(frozen=True)
class Move:
    """One trapezoidal (or triangular) move of one axis: distance `d` deg starting at `t0`."""
    t0: float
    p0: float
    d: float
    vmax: float
    amax: float

    @property
    def _shape(self) -> tuple[float, float, float]:
        dist = abs(self.d)
        vpk = min(self.vmax, np.sqrt(dist * self.amax))
        ta = vpk / self.amax
        tc = (dist - vpk * ta) / vpk if vpk > 0 else 0.0
        return vpk, ta, tc

    @property
    def duration(self) -> float:
        _, ta, tc = self._shape
        return 2 * ta + tc

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angle (deg), rate (deg/s), acceleration (deg/s^2) at times t (any t; clamps outside)."""
        vpk, ta, tc = self._shape
        sgn, a = np.sign(self.d), self.amax
        tau = np.clip(t - self.t0, 0.0, 2 * ta + tc)
        t2 = np.clip(tau - ta, 0.0, tc)
        t3 = np.clip(tau - ta - tc, 0.0, ta)
        t1 = np.minimum(tau, ta)
        pos = 0.5 * a * t1**2 + vpk * t2 + vpk * t3 - 0.5 * a * t3**2
        vel = np.where(tau < ta, a * tau, np.where(tau < ta + tc, vpk, vpk - a * t3))
        acc = np.where((tau > 0) & (tau < ta), a, np.where((tau > ta + tc) & (tau < 2 * ta + tc), -a, 0.0))
        vel = np.where((tau <= 0) | (tau >= 2 * ta + tc), 0.0, vel)
        return self.p0 + sgn * pos, sgn * vel, sgn * acc


@dataclass(frozen=True)
class Ring:
    """Damped settling oscillation of an axis after a move ends (deg, Hz, s)."""
    t0: float
    amp: float
    freq: float
    decay: float

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tau = np.maximum(t - self.t0, 0.0)
        w, k = 2 * np.pi * self.freq, 1.0 / self.decay
        e = np.where(t > self.t0, self.amp * np.exp(-k * tau), 0.0)
        s, c = np.sin(w * tau), np.cos(w * tau)
        return e * s, e * (w * c - k * s), e * ((k * k - w * w) * s - 2 * k * w * c)


@dataclass
class AxisPath:
    """Angle history of one table axis: a start angle plus a sum of moves and settling rings."""
    p_start: float
    moves: list[Move] = field(default_factory=list)
    rings: list[Ring] = field(default_factory=list)

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pos, vel, acc = np.full_like(t, self.p_start), np.zeros_like(t), np.zeros_like(t)
        for part in [*self.moves, *self.rings]:
            p, v, a = part.state(t)
            pos += p - (part.p0 if isinstance(part, Move) else 0.0)
            vel += v
            acc += a
        return pos, vel, acc


# ---------------------------------------------------------------- configuration
@dataclass(frozen=True)
class Config:
    """Everything a variant may change. Defaults are the baseline session."""
    n_orient: int = 20
    hold_s: tuple[float, float] = (5.0, 5.0)
    revisit: int = 0
    rate_hz: float = 100.0
    accel_hz: float | None = None
    gyro_hz: float | None = None
    mag_hz: float | None = None
    gyro_model: str = "instant"          # instant | mean | lpf
    gyro_lpf_tau: float = 0.005
    vmax_dps: float = 60.0
    amax_dps2: float = 120.0
    sequential_axes: bool = False
    long_moves: bool = False
    move_pad_s: float = 0.0
    hold_early_s: float = 0.0
    ring_deg: float = 0.0
    reference: str = "table"             # table | optical
    optical_noise_deg: float = 0.03
    sign_flips: bool = False
    wrap_angles: bool = False
    t0: float = 0.0
    jitter_s: float = 0.0
    jitter_kind: str = "true"            # true: samples taken at jittered instants; stamp: stamps noisy
    drop_move_rows: int = 0
    mount: str = "small"                 # small | rot90 | rot30 | perm | flip (board upside down)
    gyro_bias_dps: float = 1.5
    accel_lsb_per_g: float = 8192.0
    gyro_lsb_per_dps: float = 131.0
    mag_lsb_per_uT: float = 68.42
    hard_iron_fields: float = 0.3        # |B_mag| in multiples of the field
    soft_iron: float = 0.02
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    noise_lsb: tuple[float, float, float] = (0.7, 2.0, 1.5)   # accel, gyro, mag
    temperature: bool = True
    gravity: float = 9.80210
    field_uT: float = 47.3
    inclination_deg: float = 64.0
    declination_deg: float = 12.0
    column_style: str = "plain"          # plain | odd (other names, mag columns first)
    sensors: tuple[str, ...] = ("accel", "gyro", "mag")
    step_offset: int = 0                 # orientation indices need not start at 0
    extra_columns: bool = False          # vsupply_v plus a column the spec does not name


VARIANTS: dict[str, dict] = {
    "baseline": {},
    "rate200": {"rate_hz": 200.0},
    "rate50": {"rate_hz": 50.0},
    "gyro_mean": {"gyro_model": "mean"},
    "gyro_lpf5ms": {"gyro_model": "lpf"},
    "slow_moves": {"vmax_dps": 15.0, "amax_dps2": 30.0},
    "fast_moves": {"vmax_dps": 200.0, "amax_dps2": 800.0, "gyro_lsb_per_dps": 65.5},
    "fast_moves_mean": {"vmax_dps": 200.0, "amax_dps2": 800.0, "gyro_lsb_per_dps": 65.5, "gyro_model": "mean"},
    "sequential_axes": {"sequential_axes": True},
    "long_moves": {"long_moves": True},
    "optical": {"reference": "optical"},
    "optical_noisy": {"reference": "optical", "optical_noise_deg": 0.05},
    "optical_signflip": {"reference": "optical", "sign_flips": True},
    "wrapped_angles": {"wrap_angles": True},
    "unix_time": {"t0": 1.7e9},
    "jitter_true": {"jitter_s": 0.0005},
    "jitter_stamp": {"jitter_s": 0.0005, "jitter_kind": "stamp"},
    "drop_row": {"drop_move_rows": 1},
    "unix_jitter_drop": {"t0": 1.7e9, "jitter_s": 0.0005, "drop_move_rows": 1},
    "multirate_mag75": {"rate_hz": 200.0, "accel_hz": 100.0, "gyro_hz": 200.0, "mag_hz": 75.0},
    "multirate_mag10": {"rate_hz": 200.0, "accel_hz": 100.0, "gyro_hz": 200.0, "mag_hz": 10.0},
    "unequal_holds": {"hold_s": (3.0, 8.0)},
    "orient12": {"n_orient": 12},
    "orient16": {"n_orient": 16},
    "revisit": {"n_orient": 20, "revisit": 4},
    "mount_rot90": {"mount": "rot90"},
    "mount_rot30": {"mount": "rot30"},
    "mount_perm": {"mount": "perm", "column_style": "odd"},
    "mount_flip": {"mount": "flip"},
    "fullscale_smallbias": {"gyro_lsb_per_dps": 16.4, "accel_lsb_per_g": 1000.0, "hard_iron_fields": 4.0,
                            "soft_iron": 0.10, "vmax_dps": 120.0, "amax_dps2": 240.0},
    "fullscale": {"gyro_bias_dps": 5.0, "gyro_lsb_per_dps": 16.4, "accel_lsb_per_g": 1000.0, "hard_iron_fields": 4.0,
                  "soft_iron": 0.10, "vmax_dps": 120.0, "amax_dps2": 240.0},
    "lever_arm": {"lever_arm_m": (0.06, -0.08, 0.05), "vmax_dps": 120.0, "amax_dps2": 400.0},
    "ringing": {"ring_deg": 0.03},
    "hold_early": {"hold_early_s": 0.3, "ring_deg": 0.02},
    "hold_early_long": {"hold_early_s": 0.8},
    "move_padding": {"move_pad_s": 0.4},
    "gyro_lpf20ms": {"gyro_model": "lpf", "gyro_lpf_tau": 0.02},
    "fast_50hz": {"rate_hz": 50.0, "vmax_dps": 200.0, "amax_dps2": 800.0, "gyro_lsb_per_dps": 65.5},
    "fast_lpf_50hz": {"rate_hz": 50.0, "vmax_dps": 200.0, "amax_dps2": 800.0, "gyro_lsb_per_dps": 65.5,
                      "gyro_model": "lpf"},
    "fast_mean_50hz": {"rate_hz": 50.0, "vmax_dps": 200.0, "amax_dps2": 800.0, "gyro_lsb_per_dps": 65.5,
                       "gyro_model": "mean"},
    "combo": {"reference": "optical", "rate_hz": 200.0, "accel_hz": 100.0, "gyro_hz": 200.0, "mag_hz": 75.0,
              "gyro_model": "lpf", "hold_s": (3.0, 8.0), "n_orient": 16, "revisit": 3, "t0": 1.7e9,
              "lever_arm_m": (0.06, -0.08, 0.05), "ring_deg": 0.02, "sequential_axes": True, "mount": "rot30"},
    "odd_columns": {"column_style": "odd"},
    "no_mag": {"sensors": ("accel", "gyro")},
    "gyro_only": {"sensors": ("gyro",)},
    "step_from_1": {"step_offset": 1},
    "extra_columns": {"extra_columns": True, "temperature": False},
}


# ---------------------------------------------------------------- truth
@dataclass(frozen=True)
class SensorTruth:
    """Raw model y = K u + B (counts); the calibration H is K^-1."""
    name: str
    unit: str
    columns: tuple[str, str, str]
    K: np.ndarray
    B: np.ndarray
    noise: float
    rate_hz: float

    @property
    def H(self) -> np.ndarray:
        return np.linalg.inv(self.K)


def mounting(kind: str, rng: np.random.Generator) -> np.ndarray:
    """Rotation sensor -> fixture of the board (a sensor may also be rotated on the board)."""
    small = quat_to_matrix(quat_exp(rng.normal(0, 0.5 * DEG, 3)))
    big = {"small": np.eye(3), "rot90": rot_z(90 * DEG) @ rot_x(90 * DEG), "rot30": rot_x(30 * DEG) @ rot_z(-30 * DEG),
                  "perm": np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 0]]), "flip": rot_x(180 * DEG)}[kind]
    return big @ small


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def make_sensor(name: str, cfg: Config, rng: np.random.Generator, mount: np.ndarray) -> SensorTruth:
    """Counts per unit along sensor axes, with scale errors, non-orthogonality and (mag) soft iron."""
    scale = {"accel": cfg.accel_lsb_per_g / cfg.gravity, "gyro": cfg.gyro_lsb_per_dps / DEG,
             "mag": cfg.mag_lsb_per_uT}[name]
    skew = np.triu(rng.normal(0, 0.004, (3, 3)), 1)
    S = np.diag(scale * (1 + rng.normal(0, 0.02, 3))) @ (np.eye(3) + skew)
    if name == "mag":
        a = rng.normal(0, 1, (3, 3))
        soft = (a + a.T) / 2
        S = S @ (np.eye(3) + cfg.soft_iron * soft / np.abs(np.linalg.eigvalsh(soft)).max())
    K = S @ mount.T
    B_phys = {"accel": 0.4, "gyro": cfg.gyro_bias_dps * DEG, "mag": cfg.hard_iron_fields * cfg.field_uT}[name]
    direction = rng.normal(0, 1, 3)
    B = B_phys * scale * direction / np.linalg.norm(direction)
    rate = {"accel": cfg.accel_hz, "gyro": cfg.gyro_hz, "mag": cfg.mag_hz}[name] or cfg.rate_hz
    unit = {"accel": "m/s^2", "gyro": "rad/s", "mag": "uT"}[name]
    noise = cfg.noise_lsb[["accel", "gyro", "mag"].index(name)]
    cols = tuple(f"{name[0]}{c}" for c in "xyz")
    if cfg.column_style == "odd":
        cols = tuple(f"{name}_raw{i}" for i in range(3))
    return SensorTruth(name, unit, cols, K, B, noise, rate)


# ---------------------------------------------------------------- schedule
def orientation_schedule(cfg: Config, rng: np.random.Generator) -> np.ndarray:
    """(n, 2) outer/inner angles in deg: random, kept only if gravity and field directions in the
    fixture frame spread well enough for H and B to be observable (smallest singular value check)."""
    m_world = field_world(cfg) / cfg.field_uT
    n_new = cfg.n_orient - cfg.revisit
    for _ in range(1000):
        ang = np.column_stack([rng.uniform(0, 360, n_new), rng.uniform(0, 360, n_new)]).round(1)
        R = rot_x(ang[:, 0] * DEG) @ rot_z(ang[:, 1] * DEG)
        ok = True
        for w in (np.array([0, 0, 1.0]), m_world):
            v = np.einsum("nji,j->ni", R, w)
            design = np.column_stack([v, np.ones(n_new)])
            ok &= np.linalg.svd(design, compute_uv=False)[-1] > 0.45 * np.sqrt(n_new / 4)
        if ok:
            break
    if cfg.revisit:
        again = rng.choice(n_new, cfg.revisit, replace=False)
        slots = np.sort(rng.choice(np.arange(2, cfg.n_orient), cfg.revisit, replace=False))
        rows = list(ang)
        for slot, k in zip(slots, again):
            rows.insert(slot, ang[k])
        ang = np.array(rows)
    return ang


def field_world(cfg: Config) -> np.ndarray:
    inc, dec = cfg.inclination_deg * DEG, cfg.declination_deg * DEG
    return cfg.field_uT * np.array([np.cos(inc) * np.cos(dec), np.cos(inc) * np.sin(dec), -np.sin(inc)])


@dataclass
class Timeline:
    outer: AxisPath
    inner: AxisPath
    hold_start: np.ndarray   # label time a hold begins
    hold_end: np.ndarray     # label time a hold ends (move label begins)
    end: float


def build_timeline(cfg: Config, ang: np.ndarray, rng: np.random.Generator) -> Timeline:
    """Holds then moves; each axis moves by the short way (or the long way when `long_moves`)."""
    outer, inner = AxisPath(ang[0, 0]), AxisPath(ang[0, 1])
    cur = ang[0].astype(float).copy()
    starts, ends = [0.0], []
    t = 0.0
    for j in range(len(ang)):
        t = starts[-1] + rng.uniform(*cfg.hold_s) + (cfg.hold_early_s if j else 0.0)
        ends.append(t)
        if j == len(ang) - 1:
            break
        t_motion = t + cfg.move_pad_s
        deltas = (ang[j + 1] - cur + 180.0) % 360.0 - 180.0
        if cfg.long_moves and j % 3 == 1:
            deltas = np.where(deltas >= 0, deltas - 360.0, deltas + 360.0)
        t_end = t_motion
        for k, path in enumerate((outer, inner)):
            if abs(deltas[k]) < 1e-9:
                continue
            mv = Move(t_end if cfg.sequential_axes else t_motion, cur[k], deltas[k], cfg.vmax_dps, cfg.amax_dps2)
            path.moves.append(mv)
            t_end = max(t_end, mv.t0 + mv.duration)
            if cfg.ring_deg:
                path.rings.append(Ring(mv.t0 + mv.duration, cfg.ring_deg * rng.uniform(0.5, 1.0), 7.0, 0.12))
        cur = cur + deltas
        starts.append(t_end + cfg.move_pad_s - cfg.hold_early_s)
    return Timeline(outer, inner, np.array(starts), np.array(ends), ends[-1])


@dataclass(frozen=True)
class Schedule:
    """A plan given from outside instead of `orientation_schedule` and the variant's holds and move limits.

    Why: to run the rig's own plans (its default, the planner's) on this simulator with its own unit and noise,
    so a claim about a plan is not measured on the rig's simulator alone. A rig commands table positions, so
    each axis turns straight from one angle to the next (not the short way the random schedules take, which
    would change the moves' lengths), both axes starting together on their own trapezoids of `vmax_dps`
    and `amax_dps2`; `settle_s` of stillness, labelled move, follows each motion (the rig's settle wait and
    status polls) before the next hold. The variant's own motion effects (padding, early holds, ringing,
    sequential axes) still apply; its `n_orient`, `hold_s`, `revisit`, `long_moves`, `vmax_dps` and
    `amax_dps2` are the schedule's instead."""
    angles_deg: tuple[tuple[float, float], ...]    # (outer, inner) of each hold, in order
    hold_s: tuple[float, ...]                      # seconds of each hold
    vmax_dps: float
    amax_dps2: float
    settle_s: float = 0.0

    def __post_init__(self) -> None:
        if len(self.angles_deg) < 2 or any(len(a) != 2 for a in self.angles_deg):
            raise ValueError("a schedule needs at least two (outer, inner) angle pairs")
        if len(self.hold_s) != len(self.angles_deg) or min(self.hold_s) <= 0:
            raise ValueError(f"a schedule needs one positive hold length per orientation ({len(self.angles_deg)})")
        if not (self.vmax_dps > 0 and self.amax_dps2 > 0 and self.settle_s >= 0):
            raise ValueError("a schedule needs positive speed and acceleration limits and a settle time >= 0")

    @classmethod
    def from_dict(cls, d: dict) -> Schedule:
        """{"orientations": [[outer, inner], ...], "hold_s": S or [S, ...], "speed_dps": V, "accel_dps2": A,
        "settle_s": T (optional)}, angles in degrees."""
        angles = tuple((float(a), float(b)) for a, b in d["orientations"])
        hold = d["hold_s"]
        holds = tuple(float(h) for h in hold) if isinstance(hold, list) else (float(hold),) * len(angles)
        return cls(angles, holds, float(d["speed_dps"]), float(d["accel_dps2"]), float(d.get("settle_s", 0.0)))


def scheduled_timeline(cfg: Config, sch: Schedule, rng: np.random.Generator) -> Timeline:
    """The timeline of an explicit schedule (see `Schedule`); `build_timeline` is the random schedules'."""
    ang = np.asarray(sch.angles_deg, float)
    outer, inner = AxisPath(ang[0, 0]), AxisPath(ang[0, 1])
    starts, ends = [0.0], []
    for j in range(len(ang)):
        ends.append(starts[-1] + sch.hold_s[j] + (cfg.hold_early_s if j else 0.0))
        if j == len(ang) - 1:
            break
        t_motion = ends[-1] + cfg.move_pad_s
        t_end = t_motion
        for k, path in enumerate((outer, inner)):
            delta = ang[j + 1, k] - ang[j, k]
            if abs(delta) < 1e-9:
                continue
            mv = Move(t_end if cfg.sequential_axes else t_motion, ang[j, k], delta, sch.vmax_dps, sch.amax_dps2)
            path.moves.append(mv)
            t_end = max(t_end, mv.t0 + mv.duration)
            if cfg.ring_deg:
                path.rings.append(Ring(mv.t0 + mv.duration, cfg.ring_deg * rng.uniform(0.5, 1.0), 7.0, 0.12))
        starts.append(t_end + sch.settle_s + cfg.move_pad_s - cfg.hold_early_s)
    return Timeline(outer, inner, np.array(starts), np.array(ends), ends[-1])


# ---------------------------------------------------------------- sampling
def sample_times(cfg: Config, sensors: list[SensorTruth], end: float, rng: np.random.Generator):
    """Row instants (union of all sensors' instants) and, per sensor, a mask of rows it fills."""
    own = {s.name: np.arange(0.0, end, 1.0 / s.rate_hz) for s in sensors}
    union = np.unique(np.round(np.concatenate(list(own.values())), 9))
    masks = {n: np.isin(union, np.round(v, 9)) for n, v in own.items()}
    return union, masks


def table_state(tl: Timeline, t: np.ndarray):
    a, ad, add = tl.outer.state(t)
    b, bd, bdd = tl.inner.state(t)
    return a, ad, add, b, bd, bdd


def rates_at(tl: Timeline, t: np.ndarray) -> np.ndarray:
    a, ad, _, b, bd, _ = table_state(tl, t)
    return body_rate(ad * DEG, b * DEG, bd * DEG)


def gyro_truth(cfg: Config, tl: Timeline, t: np.ndarray, rate_hz: float) -> np.ndarray:
    """Fixture-frame rate as the chip reports it: instantaneous, mean over the sample period, or
    first-order low-passed (simulated at 20 kHz with a bilinear discretisation)."""
    if cfg.gyro_model == "instant":
        return rates_at(tl, t)
    if cfg.gyro_model == "mean":
        nodes, weights = np.polynomial.legendre.leggauss(24)
        period = 1.0 / rate_hz
        tt = t[:, None] - period * (1 - nodes[None, :]) / 2
        return np.einsum("nkc,k->nc", rates_at(tl, tt.ravel()).reshape(len(t), len(nodes), 3), weights / 2)
    fine_dt = 5e-5
    fine = np.arange(t.min() - 0.1, t.max() + fine_dt, fine_dt)
    b, a = signal.bilinear([1.0], [cfg.gyro_lpf_tau, 1.0], fs=1 / fine_dt)
    filtered = signal.lfilter(b, a, rates_at(tl, fine), axis=0)
    return np.column_stack([np.interp(t, fine, filtered[:, c]) for c in range(3)])


def accel_truth(cfg: Config, tl: Timeline, t: np.ndarray) -> np.ndarray:
    """Specific force in the fixture frame: R^T (0,0,G) plus lever-arm terms alpha x r + w x (w x r)."""
    a, ad, add, b, bd, bdd = table_state(tl, t)
    R = rot_x(a * DEG) @ rot_z(b * DEG)
    f = cfg.gravity * R[:, 2, :]
    r = np.asarray(cfg.lever_arm_m)
    if np.any(r):
        w = body_rate(ad * DEG, b * DEG, bd * DEG)
        al = body_accel(ad * DEG, add * DEG, b * DEG, bd * DEG, bdd * DEG)
        f = f + np.cross(al, r) + np.cross(w, np.cross(w, r))
    return f


def mag_truth(cfg: Config, tl: Timeline, t: np.ndarray) -> np.ndarray:
    a, _, _, b, _, _ = table_state(tl, t)
    R = rot_x(a * DEG) @ rot_z(b * DEG)
    return np.einsum("nji,j->ni", R, field_world(cfg))


def to_counts(s: SensorTruth, u: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    y = u @ s.K.T + s.B + rng.normal(0, s.noise, u.shape)
    if y.min() < INT16[0] or y.max() > INT16[1]:
        raise ValueError(f"{s.name}: raw counts leave int16 ({y.min():.0f}..{y.max():.0f}); pick another full scale")
    return np.round(y)


# ---------------------------------------------------------------- session
@dataclass
class Session:
    cfg: Config
    sensors: list[SensorTruth]
    meta: dict
    header: list[str]
    rows: list[list[str]]

    def truth(self) -> dict:
        return {s.name: {"H": s.H.tolist(), "B": s.B.tolist(), "unit": s.unit} for s in self.sensors}


def reference_quats(cfg: Config, a_deg, b_deg, rng) -> np.ndarray:
    q = table_quat(a_deg * DEG, b_deg * DEG)
    if cfg.reference == "optical":
        q = quat_mul(q, quat_exp(rng.normal(0, cfg.optical_noise_deg * DEG, (len(q), 3))))
    q = q * np.where(q[:, :1] < 0, -1.0, 1.0)
    if cfg.sign_flips:
        q = q * rng.choice([-1.0, 1.0], (len(q), 1))
    return q


def labels(tl: Timeline, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Phase and step of each row from the label intervals (not from the motion itself)."""
    j_hold = np.searchsorted(tl.hold_start, t, side="right") - 1
    in_hold = t < tl.hold_end[j_hold]
    return np.where(in_hold, "hold", "move"), j_hold


def generate(cfg: Config, seed: int, schedule: Schedule | None = None) -> Session:
    """The session of variant `cfg` and unit `seed`; with `schedule`, that plan instead of a random one (the
    unit, drawn first, is the same either way)."""
    rng = np.random.default_rng(seed)
    board = mounting(cfg.mount, rng)
    sensors = [make_sensor(n, cfg, rng, board) for n in ("accel", "gyro", "mag")]
    sensors = [x for x in sensors if x.name in cfg.sensors]
    if schedule is None:
        ang = orientation_schedule(cfg, rng)
        tl = build_timeline(cfg, ang, rng)
    else:
        tl = scheduled_timeline(cfg, schedule, rng)
    t, masks = sample_times(cfg, sensors, tl.end, rng)
    t_true = t.copy()
    if cfg.jitter_s:
        t_true = t + rng.uniform(-cfg.jitter_s, cfg.jitter_s, len(t))
        t_true[0] = max(t_true[0], 0.0)
    stamps = t_true if cfg.jitter_kind == "true" else t + rng.uniform(-cfg.jitter_s, cfg.jitter_s, len(t))
    phase, step = labels(tl, t_true)
    keep = np.ones(len(t), bool)
    if cfg.drop_move_rows:
        moving = np.flatnonzero(phase == "move")
        keep[rng.choice(moving[len(moving) // 3: 2 * len(moving) // 3], cfg.drop_move_rows, replace=False)] = False
    a, _, _, b, _, _ = table_state(tl, t_true)
    q = reference_quats(cfg, a, b, rng)
    cols: dict[str, list[str]] = {
        "t": [f"{x + cfg.t0:.6f}" for x in stamps], "phase": list(phase), "step": [str(x + cfg.step_offset) for x in step]}
    for k, c in enumerate("wxyz"):
        cols[f"q{c}"] = [f"{x:.9f}" for x in q[:, k]]
    if cfg.reference == "table":
        wrap = (lambda x: (x + 180.0) % 360.0 - 180.0) if cfg.wrap_angles else (lambda x: x)
        cols["table_outer_deg"] = [f"{x:.5f}" for x in wrap(a)]
        cols["table_inner_deg"] = [f"{x:.5f}" for x in wrap(b)]
    order = sensors[::-1] if cfg.column_style == "odd" else sensors
    for s in order:
        m = masks[s.name]
        tm = t_true[m]
        u = {"accel": lambda: accel_truth(cfg, tl, tm), "gyro": lambda: gyro_truth(cfg, tl, tm, s.rate_hz),
             "mag": lambda: mag_truth(cfg, tl, tm)}[s.name]()
        y = to_counts(s, u, rng)
        for k, name in enumerate(s.columns):
            col = np.full(len(t), "", dtype=object)
            col[m] = [str(int(v)) for v in y[:, k]]
            cols[name] = list(col)
    if cfg.temperature:
        cols["temp_c"] = [f"{x:.2f}" for x in 24.0 + 0.004 * t + rng.normal(0, 0.05, len(t))]
    if cfg.extra_columns:
        cols["vsupply_v"] = [f"{x:.3f}" for x in 3.3 + rng.normal(0, 0.002, len(t))]
        cols["frame_id"] = [str(k) for k in range(len(t))]
    header = list(cols)
    rows = [list(r) for r in zip(*(cols[h] for h in header))]
    rows = [r for r, k in zip(rows, keep) if k]
    meta = {"format": "imu-session-csv/1", "gravity_mps2": cfg.gravity,
            "sample_rate_hz": max(s.rate_hz for s in sensors),
            "sensors": {s.name: list(s.columns) for s in order},
            "generator": "tests/independent_vary/vary_sim.py", "seed": seed}
    if "mag" in cfg.sensors:
        meta["field_uT"] = cfg.field_uT
    if cfg.reference == "table":
        meta["table"] = {"outer_axis_world": [1, 0, 0], "inner_axis_fixture": [0, 0, 1]}
    return Session(cfg, sensors, meta, header, rows)


def write_session(session: Session, out: Path) -> Path:
    """Write meta.json and samples.csv into `out`; the truth goes beside the folder (OUT.truth.json)
    so the session folder holds exactly the two files of the spec."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "meta.json").write_text(json.dumps(session.meta, indent=2))
    lines = [",".join(session.header)] + [",".join(r) for r in session.rows]
    (out / "samples.csv").write_text("\n".join(lines) + "\n")
    truth = out.parent / f"{out.name}.truth.json"
    truth.write_text(json.dumps(session.truth(), indent=2))
    return truth


def score(calibration: dict, truth: dict) -> dict:
    """Per sensor: relative Frobenius error of H and relative error of B (both in percent)."""
    out = {}
    for name, t in truth.items():
        est = calibration["sensors"].get(name)
        if est is None:
            out[name] = {"H_err_pct": float("nan"), "B_err_pct": float("nan"), "missing": True}
            continue
        H, B = np.asarray(est["H"], float), np.asarray(est["B"], float)
        Ht, Bt = np.asarray(t["H"]), np.asarray(t["B"])
        out[name] = {"H_err_pct": 100 * np.linalg.norm(H - Ht) / np.linalg.norm(Ht),
                     "B_err_pct": 100 * np.linalg.norm(B - Bt) / np.linalg.norm(Bt)}
    return out


def run_cli(session_dir: Path, out_dir: Path, *extra: str) -> subprocess.CompletedProcess:
    """Run our tool exactly as a user would, through its command line."""
    cmd = ["rig", "calibrate", "--from", str(session_dir), "--out", str(out_dir), "--no-progress", *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def sweep(variants: list[str], seeds: list[int], work: Path) -> dict:
    """Generate and calibrate every variant for every seed; keep the worst error per sensor."""
    results = {}
    for v in variants:
        worst: dict = {"errors": []}
        for seed in seeds:
            sdir = work / f"{v}_s{seed}"
            truth_path = write_session(generate(config_for(v), seed), sdir)
            proc = run_cli(sdir, work / f"{v}_s{seed}_out")
            if proc.returncode != 0:
                worst["errors"].append(f"seed {seed}: " + (proc.stderr.strip().splitlines() or ["?"])[-1])
                continue
            cal = json.loads((work / f"{v}_s{seed}_out" / "calibration.json").read_text())
            for name, e in score(cal, json.loads(truth_path.read_text())).items():
                w = worst.setdefault(name, {"H_err_pct": 0.0, "B_err_pct": 0.0})
                w["H_err_pct"] = max(w["H_err_pct"], e["H_err_pct"])
                w["B_err_pct"] = max(w["B_err_pct"], e["B_err_pct"])
        results[v] = worst
    return results


def config_for(variant: str) -> Config:
    if variant not in VARIANTS:
        raise SystemExit(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}")
    return replace(Config(), **VARIANTS[variant])


def load_schedule(path: Path) -> Schedule:
    """The schedule in a JSON file, or exit with a message saying what is wrong with it (no traceback)."""
    try:
        return Schedule.from_dict(json.loads(path.read_text()))
    except OSError as e:
        raise SystemExit(f"--schedule {path}: {e.strerror}") from None
    except KeyError as e:
        raise SystemExit(f"--schedule {path}: not a schedule (no {e} key)") from None
    except (ValueError, TypeError) as e:
        raise SystemExit(f"--schedule {path}: not a schedule ({e})") from None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="baseline", choices=list(VARIANTS))
    ap.add_argument("--sweep", type=int, metavar="N_SEEDS", help="calibrate all variants (or --variant) with "
                    "seeds 0..N-1 via `rig calibrate`, sessions under OUT; print worst errors as JSON")
    ap.add_argument("--only", nargs="*", help="with --sweep: these variants")
    ap.add_argument("--schedule", type=Path, metavar="FILE.json", help="follow this plan instead of a random one: "
                    '{"orientations": [[outer, inner], ...], "hold_s": S or [S, ...], "speed_dps": V, '
                    '"accel_dps2": A, "settle_s": T} (degrees, seconds; see Schedule)')
    args = ap.parse_args()
    if args.schedule is not None:
        if args.sweep:
            ap.error("--schedule makes one session; it does not combine with --sweep")
        write_session(generate(config_for(args.variant), args.seed, load_schedule(args.schedule)), args.out)
        return
    if args.sweep:
        names = args.only or list(VARIANTS)
        print(json.dumps(sweep(names, list(range(args.sweep)), args.out), indent=1))
        return
    write_session(generate(config_for(args.variant), args.seed), args.out)


if __name__ == "__main__":
    main()
