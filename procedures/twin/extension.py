"""Name what the twin gets wrong, extend it, measure the gain.

A statistic of the real recording outside its replicas' 1-99 % band is something the simulation gets wrong. Each
noise and recording effect of the vocabulary (effects.md, "Noise and recording effects") is fitted from the real
recording alone, by its own estimator, and proposed when a statistic it governs is out of band. The replicas are
run again with all proposed effects, and with each alone: a statistic that comes back inside is named by the
effects that bring it back alone (or all of them, when only together); one that stays outside is `unexplained`.
The poses a hand held are `procedures.twin.hold`'s; a spectrum is another colour only beyond what white noise's own
estimate shows (`white_peak_chance`).
"""

from __future__ import annotations

import math

import numpy as np

from fixtures.world.effects.noise import (BiasInstability, Quantisation, RateRandomWalk, Saturation, ShapedNoise,
                                          peak_density_ratio)
from procedures.twin.bands import band_chance
from procedures.twin.cause import Cause
from procedures.twin.hold import held_poses
from procedures.twin.draws import extension_level, level_dof
from procedures.twin.noise import pooled_noise, quiet_noise, sampled_rows
from procedures.twin.replay import Replay
from rig.calibration.recordings.recording import RecordingCalibration
from rig.discrepancy.stats import holm
from rig.noise.allan import allan_deviation, fit_noise
from rig.noise.statistics import quantum
from rig.noise.still_log import REPORT_UNIT_KEY
from rig.session_data import SessionData
from rig.units import REPORT_UNITS


CHANCE_SAMPLES = 16_384     # white noise simulated for `white_peak_chance`: bounded time and memory on a long pose


def outside(real: dict, bands: dict) -> set[str]:
    out = set()
    for name, value in real.items():
        if name in bands:
            lo, hi, _ = bands[name]
            tol = 1e-9 * max(abs(lo), abs(hi), 1e-300)
            if value < lo - tol or value > hi + tol:
                out.add(name)
    return out


def off_families(real: dict, bands: dict, off: set[str], replicas: int, alpha: float = 0.01) -> set[str]:
    """Families with more statistics outside the band than chance gives: with n replicas, a statistic the twin gets
    right still falls outside their band with probability `band_chance` (2/(n+1) below 99 replicas), so a family
    of m statistics with k outside has the binomial tail P(X >= k). Every family of the recording is asked at
    once (about 18), so the tails are Holm-corrected at alpha, as the model tests are: at alpha each, 5 of 22
    clean synthetic recordings had a family called off."""
    p = min(0.5, band_chance(replicas))
    tails = {}
    for fam in {family(n) for n in real if n in bands}:
        m = sum(1 for n in real if n in bands and family(n) == fam)
        k = sum(1 for n in off if family(n) == fam)
        tails[fam] = sum(math.comb(m, j) * p ** j * (1 - p) ** (m - j) for j in range(k, m + 1))
    return {fam for fam, adjusted in zip(tails, holm(list(tails.values()))) if adjusted < alpha}


def family(name: str) -> str:
    """'gyro.adev.x@0.01s' -> 'gyro.adev'; 'accel.spread.y[x_p]' -> 'accel.spread'."""
    return ".".join(name.split("[")[0].split("@")[0].split(".")[:2])


def propose(session: SessionData, rec: RecordingCalibration, replay: Replay, real: dict, bands: dict,
            off: set[str], replicas: int, rate: np.ndarray | None = None) -> list[Cause]:
    """The effects the real recording shows, each fitted from it, where a family of statistics it governs is out of
    band beyond chance (`off_families`). `rate`: the gyro's rate in rad/s (`procedures.twin.vibration.gyro_rate`), which
    a disturbance the accelerometer shows must agree with to be a rotation (`procedures.twin.hold.held_poses`)."""
    causes, floors = [], {}
    longest = max(rec.poses, key=lambda p: len(p.rows))
    fams = off_families(real, bands, off, replicas)
    # a hand's disturbance shows against the poses it left alone: one pose (a still log) has none to compare
    spreads_off = {"gyro.spread", "accel.spread"} & fams & {f"{s}.spread" for s in replay.sensors}
    not_still = len(rec.poses) > 1 and bool(spreads_off)
    for sensor, model in replay.sensors.items():
        first = len(causes)
        y = session.raw[sensor]
        scale = np.abs(np.diag(rec.sensors[sensor].H)) / REPORT_UNITS[sensor][1]   # reported unit per raw unit
        still = sampled_rows(y[longest.rows])
        q = None
        if f"{sensor}.step" in fams:
            q = np.array([quantum(column) for column in sampled_rows(y).T])
            if replay.units[sensor] == "counts":      # one count the replicas are rounded to already
                q = np.where(q > 1.0 + 1e-6, q, 0.0)
            q = q if q.any() else None
        shaped = bool({f"{sensor}.adev", f"{sensor}.psd"} & fams)
        if shaped:
            taps = spectral_taps(still.T, replay.rate_hz)
            shaped = peak_density_ratio(taps).max() > white_peak_chance(len(still), replay.rate_hz)
        if q is not None:
            # the noise ahead of the rounding the step implies; where poses are not still, the quiet poses' (the
            # disturbance of the others is the held poses' causes', not counted twice)
            white = (quiet_noise if not_still else pooled_noise)(session, rec, sensor, q)
            nu = level_dof(session, rec, sensor, quiet=not_still)
            if not_still:
                floors[sensor] = white
            noise = [] if shaped else [lambda seed, s=sensor, w=white, nu=nu: ShapedNoise(
                s, taps=np.ones((3, 1)), std=extension_level(w, nu, seed, s, Quantisation.name), seed=seed * 7 + 6)]
            causes.append(Cause(Quantisation.name, sensor, float((q * scale).max()),
                                {"q": (q * scale).tolist(), "noise_ahead_of_rounding_raw": white.tolist()},
                                (f"{sensor}.step", f"{sensor}.adev", f"{sensor}.psd", f"{sensor}.spread"),
                                lambda seed, s=sensor, q=q, noise=noise: [f(seed) for f in noise] + [Quantisation(s, q=q)],
                                quiet=() if shaped else (sensor,)))
        if shaped:
            std = quiet_noise(session, rec, sensor, q)
            nu = level_dof(session, rec, sensor, quiet=True)
            floors[sensor] = std
            effect = ShapedNoise(sensor, taps=taps, std=std)
            causes.append(Cause(effect.name, sensor, effect.magnitude(),
                                {"std_raw": std.tolist(), "taps": int(taps.shape[1]),
                                 "model": "the recording's own spectrum (longest pose), at its quieter poses' level"},
                                (f"{sensor}.adev", f"{sensor}.psd", f"{sensor}.spread"),
                                lambda seed, s=sensor, taps=taps, std=std, nu=nu: [ShapedNoise(
                                    s, taps=taps, std=extension_level(std, nu, seed, s, "shaped"), seed=seed * 7 + 1)],
                                quiet=(sensor,)))
        mean_fam = f"{sensor}.hold_mean" if sensor == "gyro" else f"{sensor}.norm_residual"
        if {mean_fam, f"{sensor}.bias_scatter", f"{sensor}.norm_scatter"} & fams:
            sigma = _excess_scatter(real, bands, sensor, rec)
            if (sigma > 0).any():
                centres = [float(np.mean(session.t[p.rows])) for p in rec.poses]
                tau = float(max(np.median(np.diff(centres)) if len(centres) > 1 else 10.0, 1.0))
                causes.append(Cause(BiasInstability.name, sensor,
                                    float((sigma * scale).max() * 0.618 / math.sqrt(2 * math.log(2) / math.pi)),
                                    {"sigma": (sigma * scale).tolist(), "tau_s": tau},
                                    (mean_fam, f"{sensor}.bias_scatter", f"{sensor}.norm_scatter", f"{sensor}.adev"),
                                    lambda seed, s=sensor, sg=sigma, tau=tau: [BiasInstability(s, sigma=sg, tau_s=tau,
                                                                                               seed=seed * 7 + 2)]))
        terms = fit_noise(allan_deviation(still[:, 0], replay.rate_hz))
        long_off = [n for n in off if n.startswith(f"{sensor}.adev") and _tau(n) >= 0.1 * len(still) / replay.rate_hz]
        if f"{sensor}.adev" in fams and long_off and terms.K > 0:
            K = np.array([fit_noise(allan_deviation(still[:, k], replay.rate_hz)).K for k in range(3)])
            causes.append(Cause(RateRandomWalk.name, sensor, float((K * scale).max()),
                                {"K": (K * scale).tolist()}, (f"{sensor}.adev", mean_fam, f"{sensor}.bias_scatter",
                                                              f"{sensor}.spread", f"{sensor}.psd"),
                                lambda seed, s=sensor, K=K: [RateRandomWalk(s, K=K, seed=seed * 7 + 3)]))
        if f"{sensor}.pinned" in fams:
            clean = sampled_rows(y)
            lo, hi = clean.min(axis=0), clean.max(axis=0)
            share = float(100 * np.mean((clean == lo) | (clean == hi)))
            causes.append(Cause(Saturation.name, sensor, share, {"low": lo.tolist(), "high": hi.tolist()},
                                (f"{sensor}.pinned",), lambda seed, s=sensor, lo=lo, hi=hi: [Saturation(s, low=lo, high=hi)]))
        for cause in causes[first:]:
            cause.base_unit = rec.sensors[sensor].extra.get(REPORT_UNIT_KEY)
    if not_still:
        causes += held_poses(session, rec, replay, floors, spreads_off, rate)
    return causes


def _excess_scatter(real: dict, bands: dict, sensor: str, rec: RecordingCalibration) -> np.ndarray:
    """Per axis (raw units): the pose-to-pose scatter of the means beyond what the replicas show."""
    H = rec.sensors[sensor].H
    out = np.zeros(3)
    for k, axis in enumerate("xyz"):
        name = f"{sensor}.bias_scatter.{axis}" if sensor == "gyro" else f"{sensor}.norm_scatter"
        if name in real and name in bands:
            extra = real[name] ** 2 - bands[name][2] ** 2
            out[k] = math.sqrt(max(extra, 0.0)) / abs(H[k, k])
    return out


def spectral_taps(x: np.ndarray, rate_hz: float, length: int = 64) -> np.ndarray:
    """A linear-phase FIR whose power response is the stream's Welch spectrum (frequency sampling): white noise
    through it has the stream's spectral shape. Streams along the last axis."""
    from scipy.signal import welch

    x = np.asarray(x, dtype=float)
    f, p = welch(x - x.mean(axis=-1, keepdims=True), fs=rate_hz, nperseg=min(2 * length, x.shape[-1]), axis=-1)
    taps = np.fft.irfft(np.sqrt(np.maximum(p, 1e-30)), axis=-1)
    taps = np.roll(taps, taps.shape[-1] // 2, axis=-1) * np.hanning(taps.shape[-1])
    return taps / np.linalg.norm(taps, axis=-1, keepdims=True)


def white_peak_chance(n: int, rate_hz: float, draws: int = 100) -> float:
    """The 99th percentile of the peak spectral density against white noise of the same variance
    (`peak_density_ratio`, the largest of three axes) that `spectral_taps` of n samples of white noise show: a
    spectrum estimated from a finite stream is never flat (the Xsens recording's longest pose, 5 141 samples, shows
    1.13 in the median and 1.17 here), and a recording's that peaks no more is not called another colour. Beyond
    `CHANCE_SAMPLES` the chance of that many is taken, which only makes the call harder."""
    m = min(n, CHANCE_SAMPLES)
    taps = spectral_taps(np.random.default_rng((m, 0xC010)).standard_normal((3 * draws, m)), rate_hz)
    return float(np.quantile(peak_density_ratio(taps).reshape(draws, 3).max(axis=1), 0.99))


def _tau(name: str) -> float:
    return float(name.split("@")[1].rstrip("s")) if "@" in name else 0.0
