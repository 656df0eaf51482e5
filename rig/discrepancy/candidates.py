"""The candidate library: one group of regressor columns per named effect of `effects.md` and sensor.

Each candidate test registers itself against its vocabulary name (`rig.effects`) with `@candidate_test(name,
needs=...)`: the vocabulary gives its sensors and unit, `needs` the covariates the session must have logged for it.
Each candidate turns the rows of one sensor into columns `Z` (n, 3, q) such that the residual of the
linear model gains `Z c` when the effect is present, `c` its coefficients (one label per column, the
axis the coefficient belongs to, for the Holm family of candidates x axes), and maps `c` back to the
vocabulary's magnitude and unit. Columns are first-order models of `fixtures/world/effects.py`'s
laws, written in the raw sensor axes where the effect acts after `inv(H)` (scale-like effects).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from rig.discrepancy.linear import TriadFit
from rig.discrepancy.observations import Observations
from rig.effects import EFFECTS, effect as vocabulary_entry
from rig.units import DEG, REPORT_UNITS, STANDARD_GRAVITY

AXES = ("x", "y", "z")


@dataclass
class Candidate:
    columns: Callable[[Observations, TriadFit], np.ndarray]            # (n, 3, q)
    labels: tuple[str, ...]
    magnitude: Callable[[np.ndarray], float]                          # c -> vocabulary magnitude
    params: Callable[[np.ndarray], dict] = field(default=lambda c: {})
    scan: Callable[[Observations], np.ndarray] | None = None          # values of a searched parameter
    scan_columns: Callable[[Observations, TriadFit, float], np.ndarray] | None = None
    note: str = ""
    # physics the data must agree with (e.g. the Earth's rate is 15.04 deg/h): (c, cov) -> reason or None
    implausible: Callable[[np.ndarray, np.ndarray], str | None] | None = None
    # the covariate its residual follows, for the plots: observations -> (values (n,) or (n, 3), label)
    against: Callable[[Observations], tuple[np.ndarray | None, str]] | None = None
    effect: str = ""              # set from the vocabulary when the library builds it
    sensor: str = ""
    unit: str = ""

    @property
    def key(self) -> str:
        return f"{self.effect}:{self.sensor}"


Build = Callable[[str], Candidate]
CANDIDATES: dict[str, tuple[Build, tuple[str, ...]]] = {}    # vocabulary name -> (build(sensor), needs)
COVARIATES = ("temp", "vsupply", "moves", "tumble_table")


def candidate_test(name: str, *, needs: tuple[str, ...] = ()) -> Callable[[Build], Build]:
    """Register the candidate test of effect `name`; `needs` are what the session must have for it: a varying
    temperature or supply, move windows, the tumble table of conventions.md (the geometry candidates)."""
    vocabulary_entry(name)
    unknown = set(needs) - set(COVARIATES)
    if unknown:
        raise ValueError(f"candidate {name!r} needs {sorted(unknown)}; known: {COVARIATES}")

    def register(build: Build) -> Build:
        if name in CANDIDATES:
            raise ValueError(f"effect {name!r} has two candidate tests")
        CANDIDATES[name] = (build, tuple(needs))
        return build
    return register


def _per_axis(values: np.ndarray) -> np.ndarray:
    n = len(values)
    Z = np.zeros((n, 3, 3))
    for a in range(3):
        Z[:, a, a] = values
    return Z


def _centred(x: np.ndarray) -> np.ndarray:
    return x - x.mean()


def _temperature(o: Observations):
    return o.temp, "temperature, degC"


def _time(o: Observations):
    return o.t, "time, s"


@candidate_test("temperature_bias", needs=("temp",))
def temperature_bias(sensor: str) -> Candidate:
    _, k = REPORT_UNITS[sensor]
    return Candidate(lambda o, f: _per_axis(_centred(o.temp)), AXES, lambda c: float(np.abs(c).max() / k),
                     lambda c: {"k": (c / k).tolist()}, note="bias += k (T - T0), fixture axes", against=_temperature)


@candidate_test("temperature_scale", needs=("temp",))
def temperature_scale(sensor: str) -> Candidate:
    def cols(o, f):
        z = f.predicted_z(o)
        return -f.H[None, :, :] * (_centred(o.temp)[:, None] * z)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max() * 1e6), lambda c: {"s_ppm_per_degC": (c * 1e6).tolist()},
                     note="H(T) = H (1 + s (T - T0)) per sensor axis", against=_temperature)


@candidate_test("bias_drift")
def bias_drift(sensor: str) -> Candidate:
    _, k = REPORT_UNITS[sensor]
    return Candidate(lambda o, f: _per_axis(_centred(o.t)), AXES, lambda c: float(np.abs(c).max() * 3600.0 / k),
                     lambda c: {"d_per_hour": (c * 3600.0 / k).tolist()}, against=_time)


@candidate_test("table_axis_misalignment", needs=("tumble_table",))
def table_axis_misalignment(sensor: str) -> Candidate:
    """Tilt eps of the inner axis about fixture y between the gimbals, R = Rx(a) Ry(eps) Rz(b). Zero
    offsets and tilts about x or z equal a mounting rotation (absorbed by H) or a rotated reference
    (absorbed by v), so only this component is identifiable."""
    ey = np.array([0.0, 1.0, 0.0])

    def cols(o, f):
        if f.v is None:
            Z = np.zeros((o.n, 3, 1))
            Z[:, 2, 0] = o.outer_rate          # omega gains eps * adot e_z
            return Z
        a, b = np.radians(o.angles[:, 0]), np.radians(o.angles[:, 1])
        w = _rx_T(a, f.v)
        col = -_rz_T(b, np.cross(ey, w))
        return col[:, :, None]
    return Candidate(cols, ("eps",), lambda c: float(abs(c[0]) / DEG),
                     lambda c: {"tilt_y_deg": float(c[0] / DEG), "seen_by": sensor},
                     note="only the non-orthogonality of the gimbal axes (tilt about fixture y) is identifiable",
                     against=lambda o: (o.angles[:, 0], "outer angle, deg"))


def _rx_T(a, v):
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.full_like(a, v[0]), c * v[1] + s * v[2], -s * v[1] + c * v[2]], -1)


def _rz_T(b, w):
    c, s = np.cos(b), np.sin(b)
    return np.stack([c * w[:, 0] + s * w[:, 1], -s * w[:, 0] + c * w[:, 1], w[:, 2]], -1)


@candidate_test("accel_scale_nonlinearity")
def accel_scale_nonlinearity(sensor: str) -> Candidate:
    def cols(o, f):
        colnorm = np.linalg.norm(f.H, axis=0)
        s = f.predicted_z(o) * colnorm                      # physical value along each sensor axis
        return (f.H / colnorm)[None, :, :] * (s * s)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max()), lambda c: {"K2": c.tolist()},
                     note="measured = true + K2 true^2 per sensor axis",
                     against=lambda o: (o.f, "reference specific force, m/s^2"))


@candidate_test("supply_ratiometric", needs=("vsupply",))
def supply_ratiometric(sensor: str) -> Candidate:
    return Candidate(lambda o, f: _per_axis(_centred(o.vsupply)), AXES, lambda c: float(np.abs(c).max()),
                     lambda c: {"k": c.tolist()}, against=lambda o: (o.vsupply, "supply, V"))


@candidate_test("accel_scale_asymmetry")
def accel_scale_asymmetry(sensor: str) -> Candidate:
    """Columns H[:, i] max(zhat_i, 0), zhat = inv(H) f_ref the noise-free raw value of each hold: the positive
    side of each sensor axis reads (1 + delta_i) times its scale. Of |zhat_i| the linear part goes to H and the
    rest (even in the input) stays, which the norm of gravity over many poses separates from a constant bias."""
    def cols(o, f):
        return f.H[None, :, :] * np.maximum(f.predicted_z(o), 0.0)[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max() * 100.0), lambda c: {"delta_percent": (c * 100.0).tolist()},
                     note="extra relative scale for positive values per sensor axis",
                     against=lambda o: (o.f, "reference specific force, m/s^2"))


@candidate_test("gyro_g_sensitivity")
def gyro_g_sensitivity(sensor: str) -> Candidate:
    def cols(o, f):
        Z = np.zeros((o.n, 3, 9))
        for a in range(3):
            Z[:, a, 3 * a:3 * a + 3] = o.f
        return Z
    return Candidate(cols, tuple(a for a in AXES for _ in range(3)),
                     lambda c: float(np.linalg.svd(c.reshape(3, 3), compute_uv=False)[0] * STANDARD_GRAVITY / DEG),
                     lambda c: {"Gs_deg_s_per_g": (c.reshape(3, 3) * STANDARD_GRAVITY / DEG).tolist()},
                     note="vertical Earth rate aliases into an isotropic Gs = -(Omega_v / g) I")


EARTH_RATE_DEG_H = 15.041   # sidereal rate


def _not_the_earth(c: np.ndarray, cov: np.ndarray) -> str | None:
    """The Earth's rate has a known size: a fitted |Omega| far from it is another effect with the same
    columns (an isotropic g-sensitivity looks like a vertical rate), not the Earth."""
    mag = np.linalg.norm(c) / DEG * 3600.0
    sd = np.sqrt(max(float(np.trace(cov)), 0.0)) / DEG * 3600.0
    if abs(mag - EARTH_RATE_DEG_H) > max(4.0 * sd, 0.3 * EARTH_RATE_DEG_H):
        return f"|Omega| = {mag:.3g} deg/h is not the Earth's {EARTH_RATE_DEG_H} deg/h (sd {sd:.2g})"
    return None


@candidate_test("earth_rotation")
def earth_rotation(sensor: str) -> Candidate:
    return Candidate(lambda o, f: np.transpose(o.R, (0, 2, 1)), AXES, lambda c: float(np.linalg.norm(c) / DEG * 3600.0),
                     lambda c: {"Omega_world_deg_h": (c / DEG * 3600.0).tolist()},
                     note="rate += R^T Omega; its vertical part is indistinguishable from isotropic g-sensitivity",
                     implausible=_not_the_earth)


@candidate_test("time_offset", needs=("moves",))
def time_offset(sensor: str) -> Candidate:
    return Candidate(lambda o, f: -o.rate_dot[:, :, None], ("t",), lambda c: float(c[0]), lambda c: {"tau_s": float(c[0])},
                     note="sensor reads omega(t - tau): residual = -tau d(omega)/dt",
                     against=lambda o: (np.degrees(o.rate_dot), "reference d(omega)/dt, deg/s^2"))


@candidate_test("gyro_scale_asymmetry", needs=("moves",))
def gyro_scale_asymmetry(sensor: str) -> Candidate:
    """Columns H[:, i] mean(max(zhat_i, 0)) with zhat = inv(H) omega_ref per sample: the positive part
    of the noise-free raw rate (the measured one would add E[max(noise, 0)] = 0.4 sigma at rest, a
    fake offset between still and moving rows)."""
    def cols(o, f):
        zhat = o.rate_samples @ np.linalg.inv(f.H).T
        ypos = np.nanmean(np.maximum(zhat, 0.0), axis=1)
        return f.H[None, :, :] * ypos[:, None, :]
    return Candidate(cols, AXES, lambda c: float(np.abs(c).max() * 100.0), lambda c: {"delta_percent": (c * 100.0).tolist()},
                     note="extra relative scale for positive rates per sensor axis",
                     against=lambda o: (np.degrees(o.rate), "reference rate, deg/s"))


@candidate_test("table_magnetic_disturbance", needs=("tumble_table",))
def table_magnetic_disturbance(sensor: str) -> Candidate:
    """Field of iron carried by the outer gimbal, `Rz(-inner) d`. Of d (outer-gimbal frame) only d_y is
    identifiable: d_x lies along the outer axis, so it is a world-fixed field along x that the fitted
    geomagnetic reference absorbs; d_z is fixed in the fixture frame, which the hard-iron bias absorbs."""
    def cols(o, f):
        b = np.radians(o.angles[:, 1])
        return np.stack([np.sin(b), np.cos(b), np.zeros_like(b)], -1)[:, :, None]
    return Candidate(cols, ("y",), lambda c: float(abs(c[0])), lambda c: {"d_uT": [None, float(c[0]), None]},
                     note="field += Rz(-inner) d; only d_y is identifiable (d_x is absorbed by the fitted "
                          "geomagnetic reference, d_z by the hard-iron bias), so the magnitude is |d_y|",
                     against=lambda o: (o.angles[:, 1], "inner angle, deg"))


@candidate_test("mag_offset_flip")
def mag_offset_flip(sensor: str) -> Candidate:
    """Offset step at an unknown instant: the columns are the fraction of each hold after t_flip; the
    instant is searched (hold starts and every 0.1 s inside holds) and the p-value Bonferroni-corrected."""
    def grid(o):
        holds = ~o.is_move
        starts, ends = o.t_start[holds], o.t_end[holds]
        inside = [np.arange(s, e, 0.1)[1:] for s, e in zip(starts[1:], ends[1:])]
        return np.unique(np.concatenate([starts[1:], *inside]))

    def at(o, f, t_flip):
        span = np.maximum(o.t_end - o.t_start, 1e-9)
        frac = np.clip((o.t_end - t_flip) / span, 0.0, 1.0)
        return _per_axis(frac)
    return Candidate(lambda o, f: np.zeros((o.n, 3, 3)), AXES, lambda c: float(np.linalg.norm(c)),
                     lambda c: {"step_uT": c.tolist()}, scan=grid, scan_columns=at,
                     note="offset steps at t_flip (change point in time)", against=_time)


def library(sensor: str, obs: Observations, *, tumble_table: bool = True) -> list[Candidate]:
    """The candidate of every effect of the vocabulary that acts on this sensor and whose covariates the session
    has, in the vocabulary's order. The table-geometry candidates are written for the tumble table of
    conventions.md (outer axis world x, inner axis fixture z); on another table they are left out
    (`tumble_table=False`)."""
    have = {"temp": obs.temp is not None and np.ptp(obs.temp) > 0,
            "vsupply": obs.vsupply is not None and np.ptp(obs.vsupply) > 0,
            "moves": bool(obs.is_move.any()), "tumble_table": tumble_table}
    out: list[Candidate] = []
    for name, spec in EFFECTS.items():
        if name not in CANDIDATES or sensor not in spec.tested_on:
            continue
        build, needs = CANDIDATES[name]
        if all(have[n] for n in needs):
            out.append(replace(build(sensor), effect=name, sensor=sensor, unit=spec.unit_for(sensor)))
    return out
