"""Each axis's offset against die temperature from a still log taken while the unit warms (or cools).

A board left still while it comes to temperature (PX4's thermal calibration log, ArduPilot's INS_TCAL learning,
any still log that carries the chip's thermometer) reads on each gyroscope axis its bias plus the Earth's rate
along that axis, and on each accelerometer axis its offset plus its scale times the gravity component on it. The
board does not move, so the second parts are constants: the log gives each axis's reading against temperature
up to a constant, i.e. the offset's change with temperature (for the accelerometer mixed with the scale's change
times the gravity component on that axis, which one pose cannot separate; the axes across gravity read their
offset's change alone).

Bands: the samples are grouped by temperature into `bands` bands of equal width over the logged range (PX4's
script averages in bins of temperature the same way). A band's mean reading is one point; the variance of that
mean is taken from batch means of what is left once the band's own straight line in temperature is taken out
(the curve moves across a band's width, and would otherwise count as noise): the residuals in time order cut
into `BATCHES` contiguous batches, var(mean) = var(batch means) / BATCHES, so a wandering bias counts at the
size it has over a batch's time, not as white noise. A bias that wanders more slowly than a batch is under-counted
that way; with the log's sample rate known, the variance is at least the Allan variance of the log's residual
stream (its readings less one cubic in temperature through the whole log, in time order) at the band's duration
(rig.noise.allan; IEEE 952: the Allan variance at tau is half the mean square difference of consecutive
tau-means, for white noise the variance of one tau-mean, for a wandering bias about the scatter a band's mean
shows). A band with fewer than `BATCHES * MIN_BATCH_SAMPLES` samples is not used.

Fit: each axis a polynomial in (T - T_ref), T_ref the middle of the used bands' range; its order chosen by
leaving out each interior band in turn (polynomial.choose_order, the thermal model's own test) and its
coefficients fitted by the thermal model's least squares (curves.fit_terms) over the bands' variances, the
band's temperature spread entering by its effective variance. Valid from the coldest band to the hottest;
refused outside (model.TemperatureOutOfRange), never extrapolated.

Held out (`held_out`): every other interior band is left out, the model fitted to the rest (the coldest and the
hottest kept, so every prediction interpolates) and its prediction compared with the left-out band's mean; the
peers (peers.py) on the same training data: PX4's cubic through the training bands, ArduPilot's learning on the
training bands' samples in time order. Both peers correct the offset from one calibration made at one
temperature, so both are anchored, as a unit would be, at the training band nearest the middle of the training
range (its mean reading). The noise floor of the comparison is the RMS of the left-out bands' own deviations:
what a perfect model would still show.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.thermal.curves import TermCurves, fit_terms
from rig.calibration.thermal.model import TemperatureOutOfRange
from rig.calibration.thermal.peers import (ARDUPILOT_MIN_SAMPLES, OffsetPolynomial, ardupilot_bins,
                                           ardupilot_offset_fit, px4_offset_fit)
from rig.errors import InputError
from rig.noise.allan import allan_deviation
from rig.noise.still import STILL_RATIO, stillness_ratio
from rig.session_data import SessionData

BANDS = 16
BATCHES = 8
MIN_BATCH_SAMPLES = 10
MIN_BANDS = 5          # an interior band to leave out with three left to fit, and one more to hold out
PEER_ORDER = 3


@dataclass
class TemperatureBand:
    """One temperature band of a still log: its samples' mean temperature and reading, and their deviations."""

    temp_c: float
    temp_std_c: float
    mean: np.ndarray          # (3,) the axes' mean reading, unit of the log
    std: np.ndarray           # (3,) deviation of that mean (batch means)
    samples: int
    rows: np.ndarray = field(repr=False)   # the band's rows of the log, in time order


@dataclass
class WarmupFit:
    """One sensor's offset against temperature (module docstring), valid over `valid_c`."""

    sensor: str
    reference_c: float
    valid_c: tuple[float, float]
    curves: TermCurves
    bands: list[TemperatureBand]

    def offset_at(self, temp_c) -> np.ndarray:
        """The axes' offsets (n, 3) at temperatures `temp_c`, refused outside `valid_c`."""
        t = np.atleast_1d(np.asarray(temp_c, dtype=float))
        lo, hi = self.valid_c
        bad = ~((t >= lo) & (t <= hi))
        if bad.any():
            raise TemperatureOutOfRange(self.sensor, float(t[np.flatnonzero(bad)[0]]), self.valid_c)
        return self.curves.values(t - self.reference_c)

    def slope_at(self, temp_c) -> np.ndarray:
        t = np.atleast_1d(np.asarray(temp_c, dtype=float))
        return self.curves.slopes(t - self.reference_c)

    def to_dict(self) -> dict:
        return {"sensor": self.sensor, "reference_c": self.reference_c, "valid_c": list(self.valid_c),
                "orders": list(self.curves.orders),
                "coefficients": [c.tolist() for c in self.curves.coefficients],
                "coefficient_std": np.sqrt(np.diag(self.curves.covariance)).tolist(),
                "reduced_chi2": self.curves.reduced_chi2, "bands": len(self.bands)}


def temperature_bands(temp_c: np.ndarray, y: np.ndarray, bands: int = BANDS,
                      rate_hz: float | None = None) -> list[TemperatureBand]:
    """The log's rows (temperature (n,), readings (n, 3), in time order) grouped into `bands` bands of equal
    temperature width over the logged range; rows with a missing reading or temperature are left out, and so is a
    band with too few samples for its batch means. `rate_hz`: the log's sample rate, for the Allan floor of the
    bands' deviations (module docstring)."""
    temp_c = np.asarray(temp_c, dtype=float)
    y = np.asarray(y, dtype=float).reshape(len(temp_c), -1)
    ok = np.isfinite(temp_c) & np.all(np.isfinite(y), axis=1)
    rows = np.flatnonzero(ok)
    if rows.size == 0:
        return []
    lo, hi = float(temp_c[rows].min()), float(temp_c[rows].max())
    if hi <= lo:
        return []
    index = np.minimum(((temp_c[rows] - lo) / (hi - lo) * bands).astype(int), bands - 1)
    allan = _allan_of_residual(temp_c[rows], y[rows], rate_hz) if rate_hz else None
    out = []
    for k in range(bands):
        mine = rows[index == k]
        if mine.size < BATCHES * MIN_BATCH_SAMPLES:
            continue
        dt = temp_c[mine] - temp_c[mine].mean()
        A = np.column_stack([np.ones_like(dt), dt])
        resid = y[mine] - A @ np.linalg.lstsq(A, y[mine], rcond=None)[0]
        batches = np.array_split(np.arange(mine.size), BATCHES)
        y_means = np.stack([resid[b].mean(axis=0) for b in batches])
        t_means = np.array([dt[b].mean() for b in batches])
        std = y_means.std(axis=0, ddof=1) / np.sqrt(BATCHES)
        if allan is not None:
            std = np.maximum(std, allan(mine.size / rate_hz))
        out.append(TemperatureBand(temp_c=float(temp_c[mine].mean()),
                                   temp_std_c=float(t_means.std(ddof=1) / np.sqrt(BATCHES)),
                                   mean=y[mine].mean(axis=0), std=std, samples=int(mine.size), rows=mine))
    return out


def _allan_of_residual(temp_c: np.ndarray, y: np.ndarray, rate_hz: float):
    """tau -> (3,) Allan deviation of the readings less one unweighted cubic in temperature, interpolated in
    log-log between its octave taus (held at the ends)."""
    dt = temp_c - temp_c.mean()
    A = np.vander(dt, PEER_ORDER + 1, increasing=True)
    resid = y - A @ np.linalg.lstsq(A, y, rcond=None)[0]
    curves = [allan_deviation(resid[:, k], rate_hz) for k in range(y.shape[1])]

    def at(tau: float) -> np.ndarray:
        return np.array([float(np.exp(np.interp(np.log(tau), np.log(c.tau), np.log(c.adev)))) for c in curves])
    return at


def fit_bands(sensor: str, bands: list[TemperatureBand]) -> WarmupFit:
    """Each axis's offset polynomial through the bands, its order chosen by left-out bands (module docstring)."""
    if len(bands) < MIN_BANDS:
        raise InputError(f"sensor {sensor!r}: {len(bands)} temperature band{'s' if len(bands) != 1 else ''} with "
                         f"at least {BATCHES * MIN_BATCH_SAMPLES} samples each; a warm-up fit needs {MIN_BANDS} "
                         "(a longer log, or one that spans more temperature)")
    T = np.array([b.temp_c for b in bands])
    reference = 0.5 * (float(T.min()) + float(T.max()))
    Z = np.stack([b.mean for b in bands])
    floor = np.finfo(float).tiny
    C = np.stack([np.diag(np.maximum(b.std, floor) ** 2) for b in bands])
    temp_std = np.array([b.temp_std_c for b in bands])
    curves = fit_terms(T - reference, Z, C, temp_std)
    return WarmupFit(sensor=sensor, reference_c=reference, valid_c=(float(T.min()), float(T.max())),
                     curves=curves, bands=list(bands))


def fit_warmup(sensor: str, temp_c: np.ndarray, y: np.ndarray, bands: int = BANDS,
               rate_hz: float | None = None) -> WarmupFit:
    """`fit_bands` on the log's temperature bands (`temperature_bands`)."""
    return fit_bands(sensor, temperature_bands(temp_c, y, bands, rate_hz))


def fit_warmup_session(session: SessionData, sensor: str, bands: int = BANDS) -> WarmupFit:
    """`fit_warmup` on one sensor of a still recording that carries the chip's temperature."""
    if session.temp_c is None:
        raise InputError(f"{session.source}: the recording has no temperature column; a warm-up fit needs the "
                         "chip's temperature on every row (import with --temp COLUMN)")
    if sensor not in session.raw:
        raise InputError(f"{session.source}: no {sensor!r} in the recording; it has {', '.join(session.raw)}")
    moved = _moved_axis(session.temp_c, session.raw[sensor])
    if moved is not None:
        raise InputError(f"{session.source}: the {sensor}'s {moved[0]} axis spreads {moved[1]:.0f} times its "
                         "sample-to-sample noise once its temperature curve is taken out: the unit moved; a warm-up "
                         "fit needs a still log")
    return fit_warmup(sensor, session.temp_c, session.raw[sensor], bands, session_rate(session))


def _moved_axis(temp_c: np.ndarray, y: np.ndarray) -> tuple[str, float] | None:
    """(axis, ratio) of the first axis whose residual from one cubic in temperature is not still
    (rig.noise.still: its spread over its sample-to-sample noise above STILL_RATIO); None for a still log."""
    ok = np.isfinite(temp_c) & np.all(np.isfinite(y), axis=1)
    if ok.sum() <= PEER_ORDER + 1:
        return None
    dt = temp_c[ok] - temp_c[ok].mean()
    A = np.vander(dt, PEER_ORDER + 1, increasing=True)
    resid = y[ok] - A @ np.linalg.lstsq(A, y[ok], rcond=None)[0]
    for k, axis in enumerate("xyz"):
        ratio = stillness_ratio(resid[:, k])
        if ratio > STILL_RATIO:
            return axis, ratio
    return None


def session_rate(session: SessionData) -> float | None:
    """The recording's sample rate: as stated, else from its median time step."""
    if session.sample_rate_hz:
        return float(session.sample_rate_hz)
    steps = np.diff(np.asarray(session.t, dtype=float))
    return float(1.0 / np.median(steps)) if steps.size and np.median(steps) > 0 else None


@dataclass
class HeldOut:
    """Per method, its error (left-out bands, 3 axes) at the left-out bands; `floor` the bands' own deviation,
    `ours_std` the deviation our fit states for its prediction there."""

    temps_c: np.ndarray
    errors: dict[str, np.ndarray]
    floor: np.ndarray
    ours_std: np.ndarray
    orders: list[int]
    skipped: dict[str, str]

    def standardised(self) -> np.ndarray:
        """Our errors over what the band's and our prediction's deviations together say they can be."""
        return self.errors["ours"] / np.sqrt(self.floor ** 2 + self.ours_std ** 2)

    def rms(self) -> dict[str, np.ndarray]:
        """Per method, the RMS error of each axis over the left-out bands; 'floor' that of their deviations."""
        out = {m: np.sqrt(np.mean(e ** 2, axis=0)) for m, e in self.errors.items()}
        out["floor"] = np.sqrt(np.mean(self.floor ** 2, axis=0))
        return out


def held_out(sensor: str, temp_c: np.ndarray, y: np.ndarray, bands: int = BANDS,
             rate_hz: float | None = None) -> HeldOut:
    """Ours and the peers fitted to every other band and judged on the rest (module docstring)."""
    temp_c = np.asarray(temp_c, dtype=float)
    y = np.asarray(y, dtype=float).reshape(len(temp_c), -1)
    all_bands = temperature_bands(temp_c, y, bands, rate_hz)
    n = len(all_bands)
    test = [k for k in range(1, n - 1) if k % 2 == 1]
    train = [k for k in range(n) if k not in test]
    if len(train) < MIN_BANDS or not test:
        raise InputError(f"sensor {sensor!r}: {n} usable temperature bands; leaving every other one out needs "
                         f"{2 * MIN_BANDS - 1}")
    fitted = [all_bands[k] for k in train]
    left = [all_bands[k] for k in test]
    T_test = np.array([b.temp_c for b in left])
    Z_test = np.stack([b.mean for b in left])
    ours = fit_bands(sensor, fitted)
    errors = {"ours": ours.offset_at(T_test) - Z_test}
    skipped: dict[str, str] = {}
    T_train = np.array([b.temp_c for b in fitted])
    Z_train = np.stack([b.mean for b in fitted])
    cal = fitted[int(np.argmin(np.abs(T_train - 0.5 * (T_train.min() + T_train.max()))))]
    peers: dict[str, OffsetPolynomial] = {"px4": px4_offset_fit(T_train, Z_train, cal.mean, np.eye(3), cal.temp_c)}
    rows = np.sort(np.concatenate([b.rows for b in fitted]))
    bin_T, bin_means = ardupilot_bins(temp_c[rows], y[rows])
    if len(bin_T) > PEER_ORDER:
        peers["ardupilot"] = ardupilot_offset_fit(bin_T, bin_means, cal.mean, np.eye(3), cal.temp_c)
    else:
        skipped["ardupilot"] = (f"{len(bin_T)} bins of {ARDUPILOT_MIN_SAMPLES} samples and a 0.5 C rise in the "
                                 "training bands (a cubic needs 4): the log does not warm enough for its learning")
    for name, peer in peers.items():
        errors[name] = np.stack([peer.B_at(t) for t in T_test]) - Z_test
    ours_std = np.stack([np.sqrt(np.diag(ours.curves.covariance_at(t - ours.reference_c))) for t in T_test])
    return HeldOut(temps_c=T_test, errors=errors, floor=np.stack([b.std for b in left]), ours_std=ours_std,
                   orders=list(ours.curves.orders), skipped=skipped)
