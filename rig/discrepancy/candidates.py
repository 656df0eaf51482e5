"""The candidate library: one group of regressor columns per named effect of `effects.md` and sensor.

Each candidate turns the rows of one sensor into columns `Z` (n, 3, q) such that the residual of the
linear model gains `Z c` when the effect is present, `c` its coefficients (one label per column, the
axis the coefficient belongs to, for the Holm family of candidates x axes), and maps `c` back to the
vocabulary's magnitude and unit. Columns are first-order models of `fixtures/world/effects.py`'s
laws, written in the raw sensor axes where the effect acts after `inv(H)` (scale-like effects).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from rig.discrepancy.linear import TriadFit
from rig.units import DEG, REPORT_UNITS, STANDARD_GRAVITY
from rig.discrepancy.observations import Observations

AXES = ("x", "y", "z")
# calibrated unit -> reported unit factor (divide)


@dataclass
class Candidate:
    effect: str
    sensor: str
    columns: Callable[[Observations, TriadFit], np.ndarray]            # (n, 3, q)
    labels: tuple[str, ...]
    magnitude: Callable[[np.ndarray], float]                          # c -> vocabulary magnitude
    unit: str
    params: Callable[[np.ndarray], dict] = field(default=lambda c: {})
    scan: Callable[[Observations], np.ndarray] | None = None          # values of a searched parameter
    scan_columns: Callable[[Observations, TriadFit, float], np.ndarray] | None = None
    note: str = ""
    # physics the data must agree with (e.g. the Earth's rate is 15.04 deg/h): (c, cov) -> reason or None
    implausible: Callable[[np.ndarray, np.ndarray], str | None] | None = None

    @property
    def key(self) -> str:
        return f"{self.effect}:{self.sensor}"


def _per_axis(values: np.ndarray) -> np.ndarray:
    n = len(values)
    Z = np.zeros((n, 3, 3))
    for a in range(3):
        Z[:, a, a] = values
    return Z


def _centred(x: np.ndarray) -> np.ndarray:
    return x - x.mean()


def temperature_bias(sensor: str) -> Candidate:
    unit, k = REPORT_UNITS[sensor]
    return Candidate("temperature_bias", sensor, lambda o, f: _per_axis(_centred(o.temp)), AXES,
                     lambda c: float(np.abs(c).max() / k), f"{unit} per degC",
                     lambda c: {"k": (c / k).tolist()},
                     note="bias += k (T - T0), fixture axes")


def temperature_scale(sensor: str) -> Candidate:
    def cols(o, f):
        z = f.predicted_z(o)
        return -f.H[None, :, :] * (_centred(o.temp)[:, None] * z)[:, None, :]
    return Candidate("temperature_scale", sensor, cols, AXES, lambda c: float(np.abs(c).max() * 1e6),
                     "ppm per degC", lambda c: {"s_ppm_per_degC": (c * 1e6).tolist()},
                     note="H(T) = H (1 + s (T - T0)) per sensor axis")


def bias_drift(sensor: str) -> Candidate:
    unit, k = REPORT_UNITS[sensor]
    return Candidate("bias_drift", sensor, lambda o, f: _per_axis(_centred(o.t)), AXES,
                     lambda c: float(np.abs(c).max() * 3600.0 / k), f"{unit} per hour",
                     lambda c: {"d_per_hour": (c * 3600.0 / k).tolist()})


def accel_scale_nonlinearity() -> Candidate:
    def cols(o, f):
        colnorm = np.linalg.norm(f.H, axis=0)
        s = f.predicted_z(o) * colnorm                      # physical value along each sensor axis
        return (f.H / colnorm)[None, :, :] * (s * s)[:, None, :]
    return Candidate("accel_scale_nonlinearity", "accel", cols, AXES, lambda c: float(np.abs(c).max()),
                     "1/(m/s^2)", lambda c: {"K2": c.tolist()}, note="measured = true + K2 true^2 per sensor axis")


def supply_ratiometric() -> Candidate:
    return Candidate("supply_ratiometric", "accel", lambda o, f: _per_axis(_centred(o.vsupply)), AXES,
                     lambda c: float(np.abs(c).max()), "m/s^2 per V", lambda c: {"k": c.tolist()})


def gyro_g_sensitivity() -> Candidate:
    def cols(o, f):
        Z = np.zeros((o.n, 3, 9))
        for a in range(3):
            Z[:, a, 3 * a:3 * a + 3] = o.f
        return Z
    return Candidate("gyro_g_sensitivity", "gyro", cols, tuple(a for a in AXES for _ in range(3)),
                     lambda c: float(np.linalg.svd(c.reshape(3, 3), compute_uv=False)[0] * STANDARD_GRAVITY / DEG),
                     "deg/s per g", lambda c: {"Gs_deg_s_per_g": (c.reshape(3, 3) * STANDARD_GRAVITY / DEG).tolist()},
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


def earth_rotation() -> Candidate:
    return Candidate("earth_rotation", "gyro", lambda o, f: np.transpose(o.R, (0, 2, 1)), AXES,
                     lambda c: float(np.linalg.norm(c) / DEG * 3600.0), "deg/h",
                     lambda c: {"Omega_world_deg_h": (c / DEG * 3600.0).tolist()},
                     note="rate += R^T Omega; its vertical part is indistinguishable from isotropic g-sensitivity",
                     implausible=_not_the_earth)


def time_offset() -> Candidate:
    return Candidate("time_offset", "gyro", lambda o, f: -o.rate_dot[:, :, None], ("t",),
                     lambda c: float(c[0]), "s", lambda c: {"tau_s": float(c[0])},
                     note="sensor reads omega(t - tau): residual = -tau d(omega)/dt")


def gyro_scale_asymmetry() -> Candidate:
    """Columns H[:, i] mean(max(zhat_i, 0)) with zhat = inv(H) omega_ref per sample: the positive part
    of the noise-free raw rate (the measured one would add E[max(noise, 0)] = 0.4 sigma at rest, a
    fake offset between still and moving rows)."""
    def cols(o, f):
        zhat = o.rate_samples @ np.linalg.inv(f.H).T
        ypos = np.nanmean(np.maximum(zhat, 0.0), axis=1)
        return f.H[None, :, :] * ypos[:, None, :]
    return Candidate("gyro_scale_asymmetry", "gyro", cols, AXES, lambda c: float(np.abs(c).max() * 100.0),
                     "percent", lambda c: {"delta_percent": (c * 100.0).tolist()},
                     note="extra relative scale for positive rates per sensor axis")


def table_magnetic_disturbance() -> Candidate:
    """Field of iron carried by the outer gimbal, `Rz(-inner) d`. Of d (outer-gimbal frame) only d_y is
    identifiable: d_x lies along the outer axis, so it is a world-fixed field along x that the fitted
    geomagnetic reference absorbs; d_z is fixed in the fixture frame, which the hard-iron bias absorbs."""
    def cols(o, f):
        b = np.radians(o.angles[:, 1])
        return np.stack([np.sin(b), np.cos(b), np.zeros_like(b)], -1)[:, :, None]
    return Candidate("table_magnetic_disturbance", "mag", cols, ("y",), lambda c: float(abs(c[0])),
                     "uT", lambda c: {"d_uT": [None, float(c[0]), None]},
                     note="field += Rz(-inner) d; only d_y is identifiable (d_x is absorbed by the fitted "
                          "geomagnetic reference, d_z by the hard-iron bias), so the magnitude is |d_y|")


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
    return Candidate("table_axis_misalignment", sensor, cols, ("eps",), lambda c: float(abs(c[0]) / DEG), "deg",
                     lambda c: {"tilt_y_deg": float(c[0] / DEG), "seen_by": sensor},
                     note="only the non-orthogonality of the gimbal axes (tilt about fixture y) is identifiable")


def _rx_T(a, v):
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.full_like(a, v[0]), c * v[1] + s * v[2], -s * v[1] + c * v[2]], -1)


def _rz_T(b, w):
    c, s = np.cos(b), np.sin(b)
    return np.stack([c * w[:, 0] + s * w[:, 1], -s * w[:, 0] + c * w[:, 1], w[:, 2]], -1)


def mag_offset_flip() -> Candidate:
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
    return Candidate("mag_offset_flip", "mag", lambda o, f: np.zeros((o.n, 3, 3)), AXES,
                     lambda c: float(np.linalg.norm(c)), "uT", lambda c: {"step_uT": c.tolist()},
                     scan=grid, scan_columns=at, note="offset steps at t_flip (change point in time)")


GEOMETRY_EFFECTS = ("table_axis_misalignment", "table_magnetic_disturbance")


def library(sensor: str, obs: Observations, *, tumble_table: bool = True) -> list[Candidate]:
    """Every candidate of the vocabulary that applies to this sensor and whose covariate was logged.
    The table-geometry candidates are written for the tumble table of conventions.md (outer axis world
    x, inner axis fixture z); on another table they are left out (`tumble_table=False`)."""
    out: list[Candidate] = []
    has_t = obs.temp is not None and np.ptp(obs.temp) > 0
    if sensor in ("accel", "gyro", "mag"):
        if has_t:
            out += [temperature_bias(sensor), temperature_scale(sensor)]
        out.append(bias_drift(sensor))
        out.append(table_axis_misalignment(sensor))
    if sensor == "accel":
        out.append(accel_scale_nonlinearity())
        if obs.vsupply is not None and np.ptp(obs.vsupply) > 0:
            out.append(supply_ratiometric())
    if sensor == "gyro":
        out += [gyro_g_sensitivity(), earth_rotation()]
        if obs.is_move.any():
            out += [time_offset(), gyro_scale_asymmetry()]
    if sensor == "mag":
        out += [table_magnetic_disturbance(), mag_offset_flip()]
    return out if tumble_table else [c for c in out if c.effect not in GEOMETRY_EFFECTS]
