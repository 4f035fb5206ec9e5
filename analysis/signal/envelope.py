"""Envelope spectra: band-pass a run's signal around a resonance, take its Hilbert envelope,
and name the envelope's lines by the bearing's defect frequencies.

The impacts of a ball on a pit ring the structure's resonances; their repetition rate (BPFO,
BPFI, 2·BSF) and its modulation (by X for an inner-race pit turning through the loaded zone,
by FTF for a ball pit going round with the cage) show in the envelope of the ringing, not in
the raw spectrum, where the ringing sits at the resonance (R. B. Randall, J. Antoni,
"Rolling element bearing diagnostics—A tutorial", MSSP 25 (2011) 485–520, Sec. 3).

Steps (``scipy.signal``): the mean-free signal is filtered by a Butterworth band-pass of
order ``ORDER`` run forwards and backwards (``butter`` in second-order sections,
``sosfiltfilt``: zero phase, so the envelope is not delayed); the envelope is |hilbert(·)|,
its mean removed; its amplitude spectrum is :func:`analysis.signal.spectrum.amplitude_spectrum`
(Hann, amplitude-true). Peaks are named in the defect vocabulary
(:func:`analysis.signal.spectrum.fault_names`).

The band is the user's (``band = (lo, hi)`` in Hz), or chosen by a kurtogram-like search
(J. Antoni, "Fast computation of the kurtogram for the detection of transient faults", MSSP
21 (2007) 108–124): at levels k = 1 … ``LEVELS`` the range from 0 to the Nyquist frequency
is cut into 2^k equal bands and, shifted by half a band, 2^k − 1 more; each band at least
``min_width_hz`` wide (default: 2.5 times the highest of BPFO, BPFI and 2·BSF, so the band
passes the fault's sidebands) and clear of 0 Hz is filtered as above, and the band whose
complex envelope has the largest spectral kurtosis K = ⟨|a|⁴⟩/⟨|a|²⟩² − 2 (Antoni 2006;
0 for a Gaussian signal, large for repeated impulses) wins. This is the kurtogram's criterion
over a simpler set of bands (no 1/3-octave levels, Butterworth instead of the quasi-analytic
filter bank).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal
import xarray as xr

from analysis.errors import InputError
from analysis.provenance import displacement_names
from analysis.signal.spectrum import (
    Peak,
    amplitude_spectrum,
    fault_frequencies,
    find_peaks,
    time_step,
)

ORDER = 4
"""Order of the Butterworth band-pass (each direction of sosfiltfilt)."""
LEVELS = 7
"""Levels of the band search: the narrowest candidate bands are Nyquist/2^LEVELS wide."""


@dataclass(frozen=True)
class Band:
    """A pass band (Hz) and the spectral kurtosis of the signal's envelope in it."""

    low_hz: float
    high_hz: float
    kurtosis: float
    chosen: str
    """``user`` (given) or ``kurtosis`` (found by the search)."""


def parse_band(text: str) -> tuple[float, float]:
    """``"LO:HI"`` (Hz) as a pair of numbers; InputError naming ``--band`` otherwise."""
    lo, sep, hi = text.partition(":")
    try:
        band = (float(lo), float(hi))
    except ValueError:
        band = None
    if not sep or band is None or not 0 <= band[0] < band[1]:
        raise InputError(f"--band: must be LO:HI in Hz with 0 <= LO < HI, got {text!r}")
    return band


def check_band(band: tuple[float, float], fs: float, n_samples: int) -> tuple[float, float]:
    """A given pass band (Hz) as it is used, or ``InputError``: it must lie between 0 and
    the Nyquist frequency ``fs``/2 of the run (never clipped), and be at least two bins of
    the run's frequency resolution ``fs``/``n_samples`` wide (a narrower band passes
    nothing: an empty table)."""
    low, high = float(band[0]), float(band[1])
    nyquist, resolution = fs / 2, fs / n_samples
    text = f"{band[0]:g}:{band[1]:g}"
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise InputError(f"--band: must be LO:HI in Hz with 0 <= LO < HI, got {text}")
    if high > nyquist * (1 + 1e-9):
        raise InputError(f"--band: must lie in [0, {nyquist:g}] Hz, below the Nyquist "
                         f"frequency of this run (dt = {1 / fs:g} s), got {text}")
    if high - low < 2 * resolution:
        raise InputError(f"--band: must be at least {2 * resolution:.3g} Hz wide (two bins "
                         f"of this run's resolution 1/T = {resolution:.3g} Hz), got {text} "
                         f"({high - low:g} Hz)")
    return low, min(high, nyquist)  # the Nyquist frequency within rounding: as given


def _bandpass(values: np.ndarray, fs: float, low: float, high: float) -> np.ndarray:
    nyquist = fs / 2
    if low <= 0 and high >= nyquist:
        return values  # the whole band: nothing to filter
    if low <= 0:
        sos = scipy.signal.butter(ORDER, high, btype="lowpass", fs=fs, output="sos")
    elif high >= nyquist:
        sos = scipy.signal.butter(ORDER, low, btype="highpass", fs=fs, output="sos")
    else:
        sos = scipy.signal.butter(ORDER, [low, high], btype="bandpass", fs=fs, output="sos")
    return scipy.signal.sosfiltfilt(sos, values)


def spectral_kurtosis(analytic: np.ndarray) -> float:
    """K = ⟨|a|⁴⟩/⟨|a|²⟩² − 2 of a complex envelope ``a`` (0 for Gaussian noise)."""
    power = np.abs(analytic) ** 2
    mean = power.mean()
    return float((power**2).mean() / mean**2 - 2.0) if mean > 0 else 0.0


def _signal(ds: xr.Dataset, var: str) -> tuple[np.ndarray, float]:
    if var not in ds.data_vars:
        raise InputError(f"var: no variable '{var}' in the dataset; "
                         f"variables: {', '.join(map(str, ds.data_vars))}")
    values = np.asarray(ds[var].values, dtype=float)
    return values - values.mean(), 1.0 / time_step(ds)


def _default_min_width(ds: xr.Dataset, fs: float) -> float:
    faults = fault_frequencies(ds.attrs)
    top = max((max(t["BPFO"], t["BPFI"], 2 * t["BSF"]) for t in faults.values()), default=0.0)
    return 2.5 * top if top > 0 else fs / 2 ** (LEVELS + 1)


def choose_band(ds: xr.Dataset, var: str, min_width_hz: float | None = None) -> Band:
    """The band (Hz) of largest envelope kurtosis (the search of the module docstring)."""
    values, fs = _signal(ds, var)
    nyquist = fs / 2
    width_floor = _default_min_width(ds, fs) if min_width_hz is None else float(min_width_hz)
    best: Band | None = None
    for level in range(1, LEVELS + 1):
        width = nyquist / 2**level
        if width < width_floor:
            break
        starts = np.concatenate([np.arange(2**level) * width,
                                 (np.arange(2**level - 1) + 0.5) * width])
        for low in starts:
            if low <= 0:
                continue  # a band from 0 Hz holds the slow motion, not the ringing
            high = min(low + width, nyquist)
            k = spectral_kurtosis(scipy.signal.hilbert(_bandpass(values, fs, low, high)))
            if best is None or k > best.kurtosis:
                best = Band(float(low), float(high), k, "kurtosis")
    if best is None:
        raise InputError(f"--band: no band of at least {width_floor:g} Hz fits below the "
                         f"Nyquist frequency {nyquist:g} Hz; give --band LO:HI")
    return best


def envelope(ds: xr.Dataset, var: str | None = None, band: tuple[float, float] | None = None,
             min_width_hz: float | None = None) -> tuple[xr.Dataset, Band]:
    """The Hilbert envelope of ``ds[var]`` band-passed to ``band`` (Hz; None: chosen by
    kurtosis), as a run-like dataset with the variable ``<var>_envelope`` (the unit of
    ``var``) on ``t`` and the run's attrs (plus ``band_hz``), and the band used."""
    var = displacement_names(ds)[0] if var is None else var
    values, fs = _signal(ds, var)
    if band is None:
        chosen = choose_band(ds, var, min_width_hz)
    else:
        low, high = check_band(band, fs, len(values))
        analytic = scipy.signal.hilbert(_bandpass(values, fs, low, high))
        chosen = Band(low, high, spectral_kurtosis(analytic), "user")
    analytic = scipy.signal.hilbert(_bandpass(values, fs, chosen.low_hz, chosen.high_hz))
    name = f"{var}_envelope"
    units = ds[var].attrs.get("units", "")
    attrs = dict(ds.attrs)
    attrs.update(band_hz=f"{chosen.low_hz:g}:{chosen.high_hz:g}", envelope_of=var,
                 state_names=name)
    out = xr.Dataset({name: ("t", np.abs(analytic), {"units": units})},
                     coords={"t": ds["t"].values}, attrs=attrs)
    return out, chosen


def envelope_spectrum(ds: xr.Dataset, var: str | None = None,
                      band: tuple[float, float] | None = None,
                      min_width_hz: float | None = None) -> xr.DataArray:
    """Amplitude spectrum (unit of ``var``; coordinate ``frequency`` in Hz) of the envelope of
    ``ds[var]`` in ``band`` (Hz; None: chosen by kurtosis). Its attrs hold ``band_hz``
    ("LO:HI"), ``band_kurtosis`` and ``band_chosen`` (``user`` or ``kurtosis``)."""
    env, chosen = envelope(ds, var, band, min_width_hz)
    spectrum = amplitude_spectrum(env, str(env.attrs["state_names"]))
    spectrum.attrs.update(band_kurtosis=chosen.kurtosis, band_chosen=chosen.chosen)
    return spectrum


def envelope_peaks(ds: xr.Dataset, var: str | None = None,
                   band: tuple[float, float] | None = None, max_peaks: int = 8,
                   min_relative_height: float = 0.02,
                   min_width_hz: float | None = None) -> tuple[list[Peak], Band]:
    """The largest peaks of the envelope spectrum of ``ds[var]``, named in the defect
    vocabulary (``BPFO``, ``2BSF``, ``BPFI-X``…; the run needs its defect frequencies in its
    attrs), and the band used. Peaks' ``direction`` is ``<var>_envelope``."""
    env, chosen = envelope(ds, var, band, min_width_hz)
    name = str(env.attrs["state_names"])
    peaks = find_peaks(env, name, max_peaks=max_peaks,
                       min_relative_height=min_relative_height, vocabulary="fault")
    return peaks, chosen
