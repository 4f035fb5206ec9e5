"""The band search of envelope analysis: a fast kurtogram on a decimated filter bank.

Bands follow the level structure of Antoni's fast kurtogram (J. Antoni, "Fast computation
of the kurtogram for the detection of transient faults", MSSP 21 (2007) 108–124): at the
dyadic levels k = 1 … ``LEVELS`` the range from 0 to the Nyquist frequency fs/2 is cut into
2^k equal bands and, shifted by half a band, 2^k − 1 more (the bands searched before the
fast search existed); at the 1/3 levels k + log2(3) − 1 (1.6, 2.6, …) into 3·2^(k−1) bands.
A band must be at least ``min_width_hz`` wide and must not start at 0 Hz (a band from 0 Hz
holds the slow motion, not the ringing).

Each band is judged by the spectral kurtosis K = ⟨|a|⁴⟩/⟨|a|²⟩² − 2 (0 for Gaussian noise,
large for repeated impulses) of the complex envelope a of the signal band-passed by the
envelope's own filter: a Butterworth band-pass of order ``ORDER`` run forwards and backwards
(``sosfiltfilt``), whose amplitude response is |H(f)|² = 1/(1 + Ω(f)^(2·ORDER)) with Ω the
prototype frequency of the bilinear design (exact, not an approximation of the filter).

What makes it fast (an equivalent decimated scheme in place of Antoni's FIR tree):
one real FFT of the record at a fast length (``scipy.fft.next_fast_len``); per band the bins
where |H|² ≥ ``SKIRT`` are weighted by |H|², doubled (the analytic signal), shifted to 0 Hz
and inverse-transformed at a short fast length M ≥ 2 × the bins kept, all bands of one
width in one batched transform. The result is the complex envelope decimated to at least
twice its own bandwidth, where its second and fourth moments are those of the full-rate
envelope. The work per level is a few record lengths of short FFTs, against one band-pass
and one full-length Hilbert transform per band before.

The search judges the signal, not the filter: the first and last ``EDGE_BANDWIDTHS``/W
seconds of a band of width W (Hz) are left out before the kurtosis. The slowest pole of the
forward-backward Butterworth decays as exp(−1.2·W·t), so 30/W leaves exp(−36) ≈ 2e-16 of a
start-up transient (and of the wrap-around of the FFT's circular convolution). A band whose
edges would leave less than half of the record is not searched.

The slow search this one replaced is kept in the tests, as the reference the fast one is
held to (``tests/signal/references.py``: per band ``sosfiltfilt`` and
``scipy.signal.hilbert`` of the whole record, the same edges dropped).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft
import scipy.signal

ORDER = 4
"""Order of the Butterworth band-pass (each direction of sosfiltfilt); ``response`` raises
Ω to 2·ORDER = 8 by three squarings."""
LEVELS = 7
"""Dyadic levels of the band search: the narrowest dyadic bands are Nyquist/2^LEVELS wide."""
SKIRT = 1e-3
"""Bins where the forward-backward response |H|² falls below this are left out of a band's
decimated envelope (the energy weight |H|⁴ there is below 1e-6)."""
BATCH_ELEMENTS = 2**23
"""Complex values (8 bytes each) of one batched inverse FFT: bands of one width are
transformed in batches of at most this size (64 MB), whatever the record's length."""
BRIDGE = 512
"""Fewest samples of the quintic bridge from the record's end back to its start."""
EDGE_BANDWIDTHS = 30.0
"""Seconds left out at each end of a band's envelope, times the band's width (Hz)."""


@dataclass(frozen=True)
class Kurtogram:
    """Every band searched: edges (Hz), level (log2 of Nyquist/width) and the spectral
    kurtosis of its envelope with the filter's edges left out."""

    low_hz: np.ndarray
    high_hz: np.ndarray
    level: np.ndarray
    kurtosis: np.ndarray

    def best(self) -> int:
        """Index of the band of largest kurtosis (the first of equals)."""
        return int(np.argmax(self.kurtosis))

    def __len__(self) -> int:
        return int(self.low_hz.size)


def candidate_bands(fs: float, min_width_hz: float, levels: int = LEVELS,
                    third_levels: bool = True) -> list[tuple[float, float, float]]:
    """The bands searched (low Hz, high Hz, level), widest first: the dyadic levels with
    their half-shifted bands, then (``third_levels``) the 1/3 levels of Antoni's tree."""
    nyquist = fs / 2
    bands: list[tuple[float, float, float]] = []
    for level in range(1, levels + 1):
        width = nyquist / 2**level
        if width < min_width_hz:
            break
        starts = np.concatenate([np.arange(2**level) * width,
                                 (np.arange(2**level - 1) + 0.5) * width])
        bands += [(float(lo), float(min(lo + width, nyquist)), float(level))
                  for lo in starts if lo > 0]
    if third_levels:
        for level in range(1, levels + 1):
            count = 3 * 2 ** (level - 1)
            width = nyquist / count
            if width < min_width_hz:
                break
            bands += [(float(j * width), float(min((j + 1) * width, nyquist)),
                       math.log2(count)) for j in range(1, count)]
    return bands


def edge_seconds(low_hz: float, high_hz: float) -> float:
    """Time (s) left out at each end of the envelope of the band (low, high) Hz."""
    return EDGE_BANDWIDTHS / (high_hz - low_hz)


def butterworth_sos(fs: float, low: float, high: float) -> np.ndarray | None:
    """Second-order sections of the band's Butterworth filter (a high-pass for a band up to
    the Nyquist frequency, a low-pass for one from 0 Hz; None for the whole range)."""
    nyquist = fs / 2
    if low <= 0 and high >= nyquist:
        return None
    if low <= 0:
        return scipy.signal.butter(ORDER, high, btype="lowpass", fs=fs, output="sos")
    if high >= nyquist:
        return scipy.signal.butter(ORDER, low, btype="highpass", fs=fs, output="sos")
    return scipy.signal.butter(ORDER, [low, high], btype="bandpass", fs=fs, output="sos")


def _warp(f: np.ndarray | float, fs: float) -> np.ndarray:
    return np.tan(np.pi * np.minimum(np.asarray(f, dtype=float), fs / 2 * (1 - 1e-12)) / fs)


def response(f_hz: np.ndarray, fs: float, low: float, high: float,
             warped: np.ndarray | None = None) -> np.ndarray:
    """|H(f)|², the amplitude response of the band's Butterworth filter run forwards and
    backwards, at ``f_hz`` (Hz): 1/(1 + Ω^(2·ORDER)) with Ω the prototype frequency of the
    bilinear transform (frequencies pre-warped as ``scipy.signal.butter`` does; ``warped``:
    tan(π f/fs) of ``f_hz`` when already known)."""
    nyquist = fs / 2
    w = _warp(f_hz, fs) if warped is None else warped
    if low <= 0 and high >= nyquist:
        return np.ones_like(w)
    with np.errstate(divide="ignore", over="ignore"):
        if low <= 0:
            omega = w / _warp(high, fs)
        elif high >= nyquist:
            omega = _warp(low, fs) / w
        else:
            w_lo, w_hi = _warp(low, fs), _warp(high, fs)
            omega = np.divide(w_lo * w_hi, w)
            np.subtract(w, omega, out=omega)
            omega /= w_hi - w_lo
        for _ in range(3):  # Ω^8 = Ω^(2·ORDER) by squaring
            omega *= omega
        omega += 1.0
        return np.reciprocal(omega, out=omega)  # 0 where Ω is infinite (0 Hz, Nyquist)


def _support(fs: float, low: float, high: float) -> tuple[float, float]:
    """Frequencies (Hz) between which |H|² >= SKIRT."""
    nyquist = fs / 2
    limit = (1.0 / SKIRT - 1.0) ** (1.0 / (2 * ORDER))

    def to_hz(w: float) -> float:
        return float(np.arctan(w) * fs / np.pi)

    if low <= 0 and high >= nyquist:
        return 0.0, nyquist
    if low <= 0:
        return 0.0, min(nyquist, to_hz(_warp(high, fs) * limit))
    if high >= nyquist:
        return to_hz(_warp(low, fs) / limit), nyquist
    w_lo, w_hi = _warp(low, fs), _warp(high, fs)
    bw, w0sq = w_hi - w_lo, w_lo * w_hi
    root = math.sqrt((limit * bw) ** 2 + 4 * w0sq)
    return to_hz((root - limit * bw) / 2), min(nyquist, to_hz((root + limit * bw) / 2))


def spectral_kurtosis(power: np.ndarray) -> np.ndarray:
    """The spectral kurtosis K = ⟨|a|⁴⟩/⟨|a|²⟩² − 2 of a complex envelope a, from its power
    p = |a|² along the last axis: K = ⟨p²⟩/⟨p⟩² − 2 (0 for Gaussian noise, −1 for a
    constant envelope, large for impacts; 0 where the power is 0). Scale-free.

    >>> float(spectral_kurtosis(np.full(100, 4.0)))
    -1.0
    >>> float(spectral_kurtosis(np.r_[np.zeros(99), 1.0]))
    98.0
    """
    mean = power.mean(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = (power * power).mean(axis=-1) / (mean * mean) - 2.0
    return np.where(mean > 0, k, 0.0)


def bridged(values: np.ndarray, n_fft: int) -> np.ndarray:
    """``values`` continued to ``n_fft`` samples by a quintic that joins its last sample to
    its first with equal value, slope and curvature: the FFT's circular record has no jump
    (whose ringing would reach far into the record through the analytic signal of a band
    up to the Nyquist frequency)."""
    gap = n_fft - values.size
    if gap <= 0:
        return values
    ends = []
    for side in (values[-3:], values[:3]):
        y0, y1, y2 = side
        ends.append((y1, (y2 - y0) / 2, y2 - 2 * y1 + y0))  # value, slope, curvature
    (p0, v0, a0), (p1, v1, a1) = ends[0], ends[1]
    h = gap + 1  # samples n-2 … n-2+h: from the last value (one sample in) to the first
    s = (np.arange(1, gap + 1) + 1) / (h + 2)
    d0, d1 = (v0 * (h + 2), a0 * (h + 2) ** 2), (v1 * (h + 2), a1 * (h + 2) ** 2)
    # quintic Hermite on s in [0, 1] from (p0, d0) to (p1, d1)
    h0 = 1 - 10 * s**3 + 15 * s**4 - 6 * s**5
    h1 = s - 6 * s**3 + 8 * s**4 - 3 * s**5
    h2 = 0.5 * s**2 - 1.5 * s**3 + 1.5 * s**4 - 0.5 * s**5
    h3 = 10 * s**3 - 15 * s**4 + 6 * s**5
    h4 = -4 * s**3 + 7 * s**4 - 3 * s**5
    h5 = 0.5 * s**3 - s**4 + 0.5 * s**5
    bridge = (p0 * h0 + d0[0] * h1 + d0[1] * h2 + p1 * h3 + d1[0] * h4 + d1[1] * h5)
    return np.concatenate([values, bridge])


class Spectrum:
    """One real FFT of a mean-free record at a fast length: the source of every band's
    complex envelope (decimated for the search, at full rate for the envelope itself)."""

    def __init__(self, values: np.ndarray, fs: float):
        self.n = int(values.size)
        self.fs = float(fs)
        self.n_fft = scipy.fft.next_fast_len(self.n + max(BRIDGE, self.n // 100), real=True)
        self.bins = scipy.fft.rfft(bridged(values, self.n_fft))
        self.df = self.fs / self.n_fft
        self.warped = _warp(np.arange(self.bins.size) * self.df, self.fs)

    def _slice(self, low: float, high: float) -> tuple[int, np.ndarray]:
        f_a, f_b = _support(self.fs, low, high)
        k_a = max(0, math.ceil(f_a / self.df))
        k_b = min(self.bins.size - 1, math.floor(f_b / self.df))
        weights = 2.0 * response(None, self.fs, low, high,  # type: ignore[arg-type]
                                 warped=self.warped[k_a:k_b + 1])
        return k_a, self.bins[k_a:k_b + 1] * weights

    def kurtosis(self, bands: list[tuple[float, float]]) -> np.ndarray:
        """Spectral kurtosis of each band's decimated complex envelope, the filter's edges
        left out. Bands of one width share one batched inverse FFT."""
        out = np.full(len(bands), np.nan)
        groups: dict[float, list[int]] = {}
        for i, (low, high) in enumerate(bands):
            groups.setdefault(round(high - low, 6), []).append(i)
        span = (self.n - 1) / self.fs
        chunks = []
        for members in groups.values():
            length = max(self._slice(*bands[i])[1].size for i in members[:1])
            m = scipy.fft.next_fast_len(2 * length + 3)
            rows = max(1, BATCH_ELEMENTS // m)  # memory of one batch: BATCH_ELEMENTS values
            chunks += [members[j:j + rows] for j in range(0, len(members), rows)]
        for members in chunks:
            slices = [self._slice(*bands[i]) for i in members]
            length = max(s.size for _, s in slices)
            m = scipy.fft.next_fast_len(2 * length + 1)
            block = np.zeros((len(members), m), dtype=np.complex64)
            for row, (_, s) in enumerate(slices):
                top = np.abs(s).max()
                block[row, :s.size] = s / top if top > 0 else s  # K is scale-free
            envelope = scipy.fft.ifft(block, axis=-1, overwrite_x=True)
            step = self.n_fft / m / self.fs  # s between decimated samples
            for row, i in enumerate(members):
                edge = edge_seconds(*bands[i])
                if 2 * edge > span / 2:
                    continue  # the edges would leave less than half of the record
                first, last = math.ceil(edge / step), math.floor((span - edge) / step)
                z = envelope[row, first:last + 1]
                power = z.real.astype(float) ** 2 + z.imag.astype(float) ** 2
                out[i] = float(spectral_kurtosis(power))
        return out

    def analytic(self, low: float, high: float) -> np.ndarray:
        """The full-rate complex envelope (analytic signal) of the band (Hz), n samples."""
        weights = 2.0 * response(None, self.fs, low, high,  # type: ignore[arg-type]
                                 warped=self.warped)
        weights[0] /= 2.0
        spectrum = np.zeros(self.n_fft, dtype=complex)
        spectrum[:self.bins.size] = self.bins * weights
        return scipy.fft.ifft(spectrum)[:self.n]


def kurtogram(values: np.ndarray, fs: float, min_width_hz: float,
              levels: int = LEVELS, spectrum: Spectrum | None = None) -> Kurtogram:
    """The kurtosis of every candidate band (``candidate_bands``) of the mean-free record
    ``values`` sampled at ``fs`` (Hz), by the decimated scheme of the module docstring."""
    spectrum = Spectrum(values, fs) if spectrum is None else spectrum
    bands = candidate_bands(fs, min_width_hz, levels)
    if not bands:
        empty = np.zeros(0)
        return Kurtogram(empty, empty, empty, empty)
    k = spectrum.kurtosis([(lo, hi) for lo, hi, _ in bands])
    keep = np.isfinite(k)
    lows, highs, lvls = (np.array(c)[keep] for c in zip(*bands, strict=True))
    return Kurtogram(lows, highs, lvls, k[keep])
