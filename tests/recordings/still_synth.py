"""Still logs made for the noise tests: white noise, a random walk and a flicker floor of known sizes (IEEE 952's
N, K and B), and the simulated world's own terms (a Gauss-Markov bias, a warm-up) added to them."""

from __future__ import annotations

import types

import numpy as np

from rig.io.recording import recording_session
from rig.session_data import SessionData

RATE_HZ = 100.0


def white(rng: np.random.Generator, n: int, N: float) -> np.ndarray:
    """White noise of density N (unit per sqrt(Hz)): N sqrt(rate) a sample."""
    return rng.normal(0.0, N * np.sqrt(RATE_HZ), n)


def random_walk(rng: np.random.Generator, n: int, K: float) -> np.ndarray:
    """A bias integrating white noise of density K (Allan deviation K sqrt(tau / 3))."""
    return np.cumsum(rng.normal(0.0, K / np.sqrt(RATE_HZ), n))


def flicker(rng: np.random.Generator, n: int, B: float) -> np.ndarray:
    """Flicker noise whose Allan deviation is the floor B sqrt(2 ln 2 / pi): one-sided PSD h / f with h = B^2 / pi
    (IEEE 952 C.1.3), drawn in the frequency domain over twice the length and cut (no wrap-around): the m-point
    DFT of such a series has E|X_j|^2 = S(f_j) rate m / 2."""
    m = 2 * n
    f = np.fft.rfftfreq(m, 1.0 / RATE_HZ)
    amplitude = np.zeros(len(f))
    amplitude[1:] = np.sqrt(B ** 2 / np.pi / f[1:] * RATE_HZ * m / 2)
    spectrum = amplitude * (rng.normal(size=len(f)) + 1j * rng.normal(size=len(f))) / np.sqrt(2)
    return np.fft.irfft(spectrum, m)[:n]


def times(seconds: float) -> np.ndarray:
    return np.arange(int(round(seconds * RATE_HZ))) / RATE_HZ


def with_term(term, t: np.ndarray, stream: np.ndarray) -> np.ndarray:
    """A simulated world's term (`fixtures.world.effects`) added to a stream (n, 3) where it acts on the sampled
    output; it reads the time only."""
    return term.output(types.SimpleNamespace(t=t), stream)


def session(t: np.ndarray, streams: dict[str, np.ndarray], units: dict[str, str]) -> SessionData:
    return recording_session(t, streams, units=units, source="<still log>", sample_rate_hz=RATE_HZ)
