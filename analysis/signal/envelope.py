"""Envelope spectra: band-pass a run's signal around a resonance, take its Hilbert envelope,
and name the envelope's lines by the bearing's defect frequencies.

The impacts of a ball on a pit ring the structure's resonances; their repetition rate (BPFO,
BPFI, 2·BSF) and its modulation (by X for an inner-race pit turning through the loaded zone,
by FTF for a ball pit going round with the cage) show in the envelope of the ringing, not in
the raw spectrum, where the ringing sits at the resonance (R. B. Randall, J. Antoni,
"Rolling element bearing diagnostics—A tutorial", MSSP 25 (2011) 485–520, Sec. 3).

Steps: the mean-free signal is band-passed by a Butterworth filter of order
``kurtogram.ORDER`` run forwards and backwards (zero phase: |H(f)|², applied to one FFT of
the record at a fast length), the envelope is the modulus of the analytic signal, the first
and last ``kurtogram.EDGE_BANDWIDTHS``/W seconds of a band W Hz wide are left out (the
filter's start-up, not the signal), and the envelope's amplitude spectrum is
:func:`analysis.signal.spectrum.amplitude_spectrum` (Hann, amplitude-true, mean removed).
Peaks are named in the defect vocabulary (:func:`analysis.signal.spectrum.fault_names`).

The band is the user's (``band = (lo, hi)`` in Hz), or the one of largest spectral kurtosis
in the fast kurtogram of :mod:`analysis.signal.kurtogram` (dyadic and 1/3 levels, each band
at least ``min_width_hz`` wide; default 2.5 × the highest of BPFO, BPFI and 2·BSF, so the
band passes the fault's sidebands).

BPFO = VC for a fixed outer race: the varying compliance alone makes a line at BPFO. The
band's ``note`` says whether the band holds a structural resonance of the model (a sprung
body's √(k/m)/2π, e.g. the housing of the 6205 defect models): only there does a BPFO line
come from impacts ringing the structure; elsewhere it may be the rotor's own VC harmonics.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np
import scipy.fft
import xarray as xr

from analysis.errors import InputError
from analysis.provenance import displacement_names
from analysis.signal import kurtogram as kg
from analysis.signal.spectrum import (
    Peak,
    amplitude_spectrum,
    fault_frequencies,
    find_peaks,
    time_step,
)

ORDER = kg.ORDER
"""Order of the Butterworth band-pass (each direction of the zero-phase filter)."""
LEVELS = kg.LEVELS
"""Dyadic levels of the band search: the narrowest dyadic bands are Nyquist/2^LEVELS wide."""


@dataclass(frozen=True)
class Band:
    """A pass band (Hz) and the spectral kurtosis of the signal's envelope in it."""

    low_hz: float
    high_hz: float
    kurtosis: float
    chosen: str
    """``user`` (given), ``kurtosis`` (found by the search) or ``resonance`` (found by the
    search among the bands holding a structural resonance)."""
    edge_s: float = 0.0
    """Time (s) left out at each end of the envelope: the filter's start-up."""
    resonances_hz: tuple[float, ...] = ()
    """The model's structural resonances (Hz, √(k/m)/2π of each sprung body) in the band."""
    note: str = ""
    """What a BPFO line in this band means (BPFO = VC for a fixed outer race)."""


RESONANCE = "resonance"
"""The band argument that asks for the band of largest kurtosis among those holding a
structural resonance of the model: where an outer-race fault is judged (BPFO = VC)."""


def parse_band(text: str) -> tuple[float, float] | str:
    """``"LO:HI"`` (Hz) as a pair of numbers, or ``"resonance"`` (:data:`RESONANCE`);
    InputError naming ``band`` otherwise."""
    if text.strip().lower() == RESONANCE:
        return RESONANCE
    lo, sep, hi = text.partition(":")
    try:
        band = (float(lo), float(hi))
    except ValueError:
        band = None
    if not sep or band is None or not 0 <= band[0] < band[1]:
        raise InputError(f"band: must be LO:HI in Hz with 0 <= LO < HI, got {text!r}", field="band")
    return band


def check_band(band: tuple[float, float], fs: float, n_samples: int) -> tuple[float, float]:
    """A given pass band (Hz) as it is used, or ``InputError``: it must lie between 0 and
    the Nyquist frequency ``fs``/2 of the run (never clipped), be at least two bins of
    the run's frequency resolution ``fs``/``n_samples`` wide (a narrower band passes
    nothing: an empty table), and leave at least half of the record once the filter's edges
    (``kurtogram.EDGE_BANDWIDTHS``/width seconds at each end) are left out."""
    low, high = float(band[0]), float(band[1])
    nyquist, resolution = fs / 2, fs / n_samples
    text = f"{band[0]:g}:{band[1]:g}"
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise InputError(f"band: must be LO:HI in Hz with 0 <= LO < HI, got {text}", field="band")
    if high > nyquist * (1 + 1e-9):
        raise InputError(f"band: must lie in [0, {nyquist:g}] Hz, below the Nyquist "
                         f"frequency of this run (dt = {1 / fs:g} s), got {text}", field="band")
    if high - low < 2 * resolution:
        raise InputError(f"band: must be at least {2 * resolution:.3g} Hz wide (two bins "
                         f"of this run's resolution 1/T = {resolution:.3g} Hz), got {text} "
                         f"({high - low:g} Hz)", field="band")
    narrowest = 4 * kg.EDGE_BANDWIDTHS * fs / max(n_samples - 1, 1)
    if high - low < narrowest:
        raise InputError(f"band: must be at least {narrowest:.3g} Hz wide for this "
                         f"{(n_samples - 1) / fs:g} s record (the filter's edges, "
                         f"{kg.EDGE_BANDWIDTHS:g}/width s at each end, must leave half of "
                         f"it), got {text} ({high - low:g} Hz)", field="band")
    return low, min(high, nyquist)  # the Nyquist frequency within rounding: as given


def _signal(ds: xr.Dataset, var: str) -> tuple[np.ndarray, float]:
    if var not in ds.data_vars:
        raise InputError(f"var: no variable '{var}' in the dataset; "
                         f"variables: {', '.join(map(str, ds.data_vars))}")
    values = np.asarray(ds[var].values, dtype=float)
    return values - values.mean(), 1.0 / time_step(ds)


def default_min_width(ds: xr.Dataset, fs: float) -> float:
    """2.5 × the highest of BPFO, BPFI and 2·BSF (Hz), so a band passes the sidebands."""
    faults = fault_frequencies(ds.attrs)
    top = max((max(t["BPFO"], t["BPFI"], 2 * t["BSF"]) for t in faults.values()), default=0.0)
    return 2.5 * top if top > 0 else fs / 2 ** (LEVELS + 1)


def structural_resonances(attrs: dict) -> tuple[float, ...]:
    """√(k/m)/2π (Hz) of each sprung body of a run that carries a bearing
    (``Model.support_resonances`` of the run's model at its parameters: found by the
    model's structure, not by parameter names), e.g. the housing of the 6205 defect models
    (the body alone on its support, the bearing's coupling left out). A record that names
    no model (a synthetic signal) has none."""
    if "model" not in attrs:
        return ()
    from analysis.provenance import system_of_attrs

    system = system_of_attrs(attrs)
    return system.model.support_resonances(dict(system.parameters))


def named_defects(attrs: dict) -> tuple[str, ...]:
    """The races (``outer``, ``inner``, …) on which the run's model has a localized defect
    term (its generated ``TERMS``); () for a healthy model or no model."""
    if "model" not in attrs:
        return ()
    from analysis.provenance import system_of_attrs

    terms = getattr(system_of_attrs(attrs).model.module, "TERMS", ())
    return tuple(re.match(r"localized defect on the (\w+)", t).group(1) for t in terms
                 if re.match(r"localized defect on the (\w+)", t))


def band_note(low: float, high: float, attrs: dict) -> tuple[tuple[float, ...], str]:
    """The structural resonances (Hz) inside the band, and what a BPFO line there means."""
    resonances = structural_resonances(attrs)
    inside = tuple(f for f in resonances if low <= f <= high)
    faults = fault_frequencies(attrs)
    if not faults:
        return inside, ""
    if attrs.get("kind") == "record":  # measured: no model, so no model resonance to check
        return inside, ("a measured record: the band is the measured signal's (largest "
                        "spectral kurtosis, or --band), with no model resonance to check it "
                        "against; a BPFO line here is the outer race's, there is no VC")
    bpfo = next(iter(faults.values()))["BPFO"]
    if inside:
        where = ", ".join(f"{f:.0f}" for f in inside)
        if "outer" in named_defects(attrs):
            return inside, (f"the band holds the structural resonance at {where} Hz: a BPFO "
                            "line here comes from impacts ringing it (the model's outer-race "
                            "defect)")
        return inside, (f"the band holds the structural resonance at {where} Hz, but the "
                        "model names no outer-race defect: a BPFO line here (BPFO = VC for a "
                        "fixed outer race) comes from the varying compliance ringing it, and "
                        "does not by itself show a defect")
    first, last = max(1, math.ceil(low / bpfo)), math.floor(high / bpfo)
    harmonics = (f"VC harmonics k = {first}…{last}" if last >= first else "no VC harmonic")
    elsewhere = (f"; the model's resonance{'s' if len(resonances) > 1 else ''} "
                 f"({', '.join(f'{f:.0f}' for f in resonances)} Hz) "
                 f"{'lie' if len(resonances) > 1 else 'lies'} outside it: judge an "
                 "outer-race fault in a band holding one (--band)" if resonances else
                 "; the model has no structural resonance for impacts to ring")
    return inside, (f"BPFO = VC = {bpfo:.2f} Hz for a fixed outer race: this band spans "
                    f"{harmonics} and no structural resonance, so a BPFO line here does not "
                    f"by itself show a defect (the varying compliance alone makes one)"
                    f"{elsewhere}")


def _with_note(band: Band, attrs: dict) -> Band:
    inside, note = band_note(band.low_hz, band.high_hz, attrs)
    return replace(band, resonances_hz=inside, note=note,
                   edge_s=kg.edge_seconds(band.low_hz, band.high_hz))


def kurtogram_of(ds: xr.Dataset, var: str | None = None,
                 min_width_hz: float | None = None) -> kg.Kurtogram:
    """Every band of the fast kurtogram of ``ds[var]`` (default: the run's first
    displacement) with its envelope's spectral kurtosis."""
    var = displacement_names(ds)[0] if var is None else var
    values, fs = _signal(ds, var)
    floor = default_min_width(ds, fs) if min_width_hz is None else float(min_width_hz)
    return kg.kurtogram(values, fs, floor)


def _best(ds: xr.Dataset, spectrum: kg.Spectrum, min_width_hz: float | None,
          resonance: bool | None = False) -> Band:
    """The band of largest kurtosis; ``resonance`` True: among those holding a structural
    resonance (refused without one); None (the default band, issue 32): among those when
    the model has a resonance inside a searched band, else among all."""
    floor = (default_min_width(ds, spectrum.fs) if min_width_hz is None
             else float(min_width_hz))
    found = kg.kurtogram(np.zeros(0), spectrum.fs, floor, spectrum=spectrum)
    if len(found) == 0:
        raise InputError(f"--band: no band of at least {floor:g} Hz fits below the "
                         f"Nyquist frequency {spectrum.fs / 2:g} Hz of this record; give "
                         "--band LO:HI")
    k = found.kurtosis
    if resonance is not False:
        resonances = structural_resonances(ds.attrs)
        holds = np.array([any(lo <= f <= hi for f in resonances)
                          for lo, hi in zip(found.low_hz, found.high_hz, strict=True)])
        if resonance is None:
            resonance = bool(holds.any())
        if resonance is True and not holds.any():
            raise InputError(f"band: {RESONANCE!r} needs a structural resonance of the "
                             "model inside a searched band (a sprung body's <body>_stiffness "
                             "and <body>_mass); " + ("this model has none" if not resonances
                             else f"{', '.join(f'{f:g}' for f in resonances)} Hz lie outside "
                             "the searched range"), field="band")
        if resonance:
            k = np.where(holds, k, -np.inf)
    i = int(np.argmax(k))
    return _with_note(Band(float(found.low_hz[i]), float(found.high_hz[i]),
                           float(found.kurtosis[i]), RESONANCE if resonance else "kurtosis"),
                      ds.attrs)


def choose_band(ds: xr.Dataset, var: str, min_width_hz: float | None = None) -> Band:
    """The band (Hz) of largest envelope kurtosis in the fast kurtogram."""
    values, fs = _signal(ds, var)
    return _best(ds, kg.Spectrum(values, fs), min_width_hz)


def envelope(ds: xr.Dataset, var: str | None = None,
             band: tuple[float, float] | str | None = None,
             min_width_hz: float | None = None) -> tuple[xr.Dataset, Band]:
    """The Hilbert envelope of ``ds[var]`` band-passed to ``band`` (Hz; None: chosen by
    kurtosis, among the bands holding a structural resonance where the model has one inside
    the search; ``"resonance"``: the band of largest kurtosis among those holding a structural
    resonance), as a run-like dataset with the variable ``<var>_envelope`` (the unit of
    ``var``) on the part of ``t`` clear of the filter's edges (cut to a fast FFT length),
    the run's attrs plus ``band_hz`` and ``envelope_of``, and the band used."""
    var = displacement_names(ds)[0] if var is None else var
    values, fs = _signal(ds, var)
    spectrum = kg.Spectrum(values, fs)
    if band is None or isinstance(band, str):
        if band is not None and band != RESONANCE:
            raise InputError(f"band: must be LO:HI in Hz or {RESONANCE!r}, got {band!r}",
                             field="band")
        chosen = _best(ds, spectrum, min_width_hz, resonance=True if band == RESONANCE
                       else None)
    else:
        low, high = check_band(band, fs, len(values))
        k = float(spectrum.kurtosis([(low, high)])[0])
        chosen = _with_note(Band(low, high, k, "user"), ds.attrs)
    analytic = spectrum.analytic(chosen.low_hz, chosen.high_hz)
    first = math.ceil(chosen.edge_s * fs)
    kept = scipy.fft.prev_fast_len(len(values) - 2 * first, real=True)
    start = first + (len(values) - 2 * first - kept) // 2
    name = f"{var}_envelope"
    units = ds[var].attrs.get("units", "")
    attrs = dict(ds.attrs)
    attrs.update(band_hz=f"{chosen.low_hz:g}:{chosen.high_hz:g}", envelope_of=var,
                 state_names=name)
    level = np.abs(analytic[start:start + kept])
    out = xr.Dataset({name: ("t", level, {"units": units})},
                     coords={"t": ds["t"].values[start:start + kept]}, attrs=attrs)
    return out, _with_level(chosen, float(np.mean(level)),
                            float(np.std(values)), units)


NEGLIGIBLE = 1e-6
"""An envelope whose mean is below this share of the signal's standard deviation holds
round-off, not a response: its band's note says so."""


def _with_level(band: Band, mean: float, spread: float, units: str) -> Band:
    """``band`` with a note added when its envelope is negligible (``NEGLIGIBLE``): issue
    41's paper model kept a 25–50 kHz default band where its envelope is about 1e-14 m."""
    if not (spread > 0 and mean < NEGLIGIBLE * spread):
        return band
    said = (f"the envelope in this band is {mean:.2g} {units}".rstrip() +
            f", {mean / spread:.1g} of the signal's standard deviation: round-off, not the "
            "response; choose a band where the signal has content (--band LO:HI)")
    return replace(band, note=f"{band.note}; {said}" if band.note else said)


def envelope_spectrum(ds: xr.Dataset, var: str | None = None,
                      band: tuple[float, float] | str | None = None,
                      min_width_hz: float | None = None) -> xr.DataArray:
    """Amplitude spectrum (unit of ``var``; coordinate ``frequency`` in Hz) of the envelope of
    ``ds[var]`` in ``band`` (Hz; None: chosen by kurtosis). Its attrs hold ``band_hz``
    ("LO:HI"), ``band_kurtosis`` and ``band_chosen`` (``user`` or ``kurtosis``)."""
    env, chosen = envelope(ds, var, band, min_width_hz)
    spectrum = amplitude_spectrum(env, str(env.attrs["state_names"]))
    spectrum.attrs.update(band_kurtosis=chosen.kurtosis, band_chosen=chosen.chosen)
    return spectrum


def envelope_peaks(ds: xr.Dataset, var: str | None = None,
                   band: tuple[float, float] | str | None = None, max_peaks: int = 8,
                   min_relative_height: float = 0.02,
                   min_width_hz: float | None = None) -> tuple[list[Peak], Band]:
    """The largest peaks of the envelope spectrum of ``ds[var]``, named in the defect
    vocabulary (``BPFO``, ``2BSF``, ``BPFI-X``…; the run needs its defect frequencies in its
    attrs; lines below the significance threshold of :func:`find_peaks` stay unnamed), and
    the band used. Peaks' ``direction`` is ``<var>_envelope``."""
    env, chosen = envelope(ds, var, band, min_width_hz)
    name = str(env.attrs["state_names"])
    peaks = find_peaks(env, name, max_peaks=max_peaks,
                       min_relative_height=min_relative_height, vocabulary="fault")
    if names_withheld(chosen, ds.attrs):
        peaks = [replace(p, label=None, shaft_order=None, vc_order=None, also=())
                 for p in peaks]
    return peaks, chosen


def names_withheld(chosen: Band, attrs: dict) -> str:
    """Why the envelope lines of ``chosen`` stay unnamed ('' : they are named): the model
    has a structural resonance and the band holds none, so no fault rings there (issue
    32: a noise-free run's femtometre band named fault lines)."""
    resonances = structural_resonances(attrs)
    if chosen.resonances_hz or not resonances:
        return ""
    return (f"no fault line named: the band {chosen.low_hz:g}:{chosen.high_hz:g} Hz holds no "
            f"structural resonance ({', '.join(f'{f:.0f}' for f in resonances)} Hz "
            f"{'lie' if len(resonances) > 1 else 'lies'} outside it); use "
            "--band resonance or a band holding one")
