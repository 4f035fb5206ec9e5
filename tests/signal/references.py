"""The slow reference implementations the fast envelope search replaced, kept here for the
tests that hold the fast one to them (they are not part of the package: minutes on a long
record).

* ``reference_kurtosis``: one band's spectral kurtosis by ``scipy.signal.sosfiltfilt`` of the
  band's Butterworth filter and ``scipy.signal.hilbert`` of the whole record, the filter's
  edges (``kurtogram.edge_seconds``) left out;
* ``reference_band``: the search as it was, every band of ``kurtogram.candidate_bands``
  (without the 1/3 levels: the bands searched before) judged by ``reference_kurtosis``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.signal
import xarray as xr

from analysis.errors import InputError
from analysis.signal import kurtogram as kg
from analysis.signal.envelope import Band, band_note, default_min_width
from analysis.signal.spectrum import time_step


def reference_kurtosis(values: np.ndarray, fs: float, low: float, high: float) -> float:
    """The slow reference of one band (Hz) of the mean-free record ``values`` sampled at
    ``fs`` (Hz): ``sosfiltfilt`` of the band's Butterworth filter, ``scipy.signal.hilbert``
    of the whole record, the same edges left out, then K (``kurtogram.spectral_kurtosis``)."""
    sos = kg.butterworth_sos(fs, low, high)
    passed = values if sos is None else scipy.signal.sosfiltfilt(sos, values)
    power = np.abs(scipy.signal.hilbert(passed)) ** 2
    edge = round(kg.edge_seconds(low, high) * fs)
    return float(kg.spectral_kurtosis(power[edge:values.size - edge]))


def reference_band(ds: xr.Dataset, var: str, min_width_hz: float | None = None,
                   third_levels: bool = False) -> Band:
    """The band of largest ``reference_kurtosis`` of ``var`` (mean removed) among the
    candidate bands at least ``min_width_hz`` wide (default ``default_min_width``), with
    its note, as ``envelope.choose_band`` returns it."""
    values = np.asarray(ds[var].values, dtype=float)
    values = values - values.mean()
    fs = 1.0 / time_step(ds)
    floor = default_min_width(ds, fs) if min_width_hz is None else float(min_width_hz)
    best: Band | None = None
    for low, high, _ in kg.candidate_bands(fs, floor, third_levels=third_levels):
        if 2 * kg.edge_seconds(low, high) > (len(values) - 1) / fs / 2:
            continue
        k = reference_kurtosis(values, fs, low, high)
        if best is None or k > best.kurtosis:
            best = Band(low, high, k, "kurtosis")
    if best is None:
        raise InputError(f"--band: no band of at least {floor:g} Hz fits this record")
    inside, note = band_note(best.low_hz, best.high_hz, ds.attrs)
    return replace(best, resonances_hz=inside, note=note,
                   edge_s=kg.edge_seconds(best.low_hz, best.high_hz))
