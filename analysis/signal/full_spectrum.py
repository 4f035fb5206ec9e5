"""Full (two-sided) spectra of an orbit: the spectrum of z = x + i·y, whose positive
frequencies are forward whirl (the orbit turning from +x towards +y, the direction of the
shaft's rotation in the shipped models) and whose negative frequencies are backward whirl.

A circular forward whirl x = r cos ωt, y = r sin ωt is z = r e^{iωt}: one line at +ω/2π of
height r. A backward whirl (y = −r sin ωt) is one line at −ω/2π. An ellipse of semi-axes
a ≥ b whirling forward at ω is (a + b)/2 at +ω and (a − b)/2 at −ω; a straight line (b = 0)
is a/2 on each side.

``full_spectrum`` is |Σ_j w_j (z_j − z̄) e^{−2πi f t_j}| / Σ_j w_j on the FFT grid (Hann
window w; frequency ``f`` in Hz from −fs/2 to fs/2), so a whirl of radius r at a bin
frequency shows a line of height r. Its lines are found and named by the project's peak
finder (``analysis.signal.spectrum.find_peaks``: refined frequency, window-corrected
amplitude, names m·X + n·VC) applied to the forward and backward circular components,
z₊ (the positive-frequency part of z) and z₋ (the negative): Re z₊ and Re z₋ are real
signals whose one-sided spectra are the two halves of the full spectrum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.speed_profile import refuse_profile
from analysis.provenance import displacement_names
from analysis.signal.spectrum import Peak, find_peaks, time_step

WHIRLS = ("forward", "backward")


@dataclass(frozen=True)
class WhirlPeak(Peak):
    """A line of a full spectrum: a ``Peak`` (``frequency_hz`` > 0, its m·X + n·VC name)
    of the forward or backward circular component (``whirl``). ``signed_frequency_hz``
    is its place on the two-sided axis (negative for backward whirl); ``name`` is
    prefixed with "-" for backward whirl (``-X``: the backward 1X line; ``-(VC-X)``)."""

    whirl: str = "forward"

    @property
    def signed_frequency_hz(self) -> float:
        """Hz: + for forward whirl, − for backward."""
        return self.frequency_hz if self.whirl == "forward" else -self.frequency_hz

    @property
    def name(self) -> str:
        """The label (``X``, ``VC-X``) or the frequency, ``-`` before it for backward
        whirl."""
        base = Peak.name.fget(self)
        if self.whirl == "forward":
            return base
        return f"-({base})" if any(sign in base for sign in "+-") else f"-{base}"

    def as_dict(self) -> dict:
        """``Peak.as_dict`` with ``whirl`` and ``signed_frequency_hz``."""
        return {**super().as_dict(), "whirl": self.whirl,
                "signed_frequency_hz": self.signed_frequency_hz}


def orbit_pair(ds: xr.Dataset, x: str | None = None, y: str | None = None
               ) -> tuple[str, str]:
    """The (x, y) variables of an orbit: ``x`` and ``y`` as given (both state variables of
    the run), or the first body's displacements. ``InputError`` naming the variable the run
    lacks, or a run whose first body moves along one coordinate."""
    if (x is None) != (y is None):
        raise InputError("var: give both coordinates of the orbit (x and y), or neither")
    if x is None:
        names = displacement_names(ds)
        if len(names) < 2:
            raise InputError(f"var: this run's first body moves along {names[0]} only; an "
                             "orbit needs two coordinates (give --var X --var Y)")
        x, y = names[:2]
    for name in (x, y):
        if name not in ds.data_vars:
            from analysis.provenance import state_names

            raise InputError(f"var: no state variable {name!r} in this run; variables: "
                             f"{', '.join(state_names(ds))}")
    return x, y


def _complex(ds: xr.Dataset, x: str, y: str) -> np.ndarray:
    z = np.asarray(ds[x].values, dtype=float) + 1j * np.asarray(ds[y].values, dtype=float)
    return z - z.mean()


def full_spectrum(ds: xr.Dataset, x: str | None = None, y: str | None = None
                  ) -> xr.DataArray:
    """The full spectrum of ``ds[x] + i·ds[y]`` (default: the first body's displacements),
    in their unit (m), over ``frequency`` (Hz, −fs/2 … fs/2, increasing): positive is
    forward whirl, negative backward (module docstring)."""
    refuse_profile(ds.attrs, "full spectrum")  # a run-up: its lines move
    x, y = orbit_pair(ds, x, y)
    dt = time_step(ds)
    z = _complex(ds, x, y)
    w = scipy.signal.get_window("hann", z.size)
    amplitude = np.fft.fftshift(np.abs(np.fft.fft(z * w))) / w.sum()
    frequency = np.fft.fftshift(np.fft.fftfreq(z.size, d=dt))
    attrs = dict(ds.attrs)
    attrs.update(units=str(ds[x].attrs.get("units", "m")), window="hann",
                 full_spectrum_of=f"{x} + i·{y}", x=x, y=y)
    return xr.DataArray(amplitude, dims="frequency",
                        coords={"frequency": ("frequency", frequency, {"units": "Hz"})},
                        name=f"{x}_{y}_full_amplitude", attrs=attrs)


def whirl_components(ds: xr.Dataset, x: str | None = None, y: str | None = None
                     ) -> xr.Dataset:
    """The forward and backward circular components of the orbit as a run: variables
    ``forward`` = Re z₊ and ``backward`` = Re z₋ (unit of x) on ``ds.t``, with the run's
    attrs (so the spectrum tools name their lines). z₊ holds the positive FFT
    frequencies of z = x + i·y (mean removed), z₋ the negative; the Nyquist bin, when
    there is one, is split evenly between them."""
    refuse_profile(ds.attrs, "full spectrum")
    x, y = orbit_pair(ds, x, y)
    z = _complex(ds, x, y)
    n = z.size
    spectrum = np.fft.fft(z)
    k = np.fft.fftfreq(n) * n
    positive = np.where(k > 0, 1.0, 0.0)
    negative = np.where(k < 0, 1.0, 0.0)
    if n % 2 == 0:  # the Nyquist bin is both +fs/2 and −fs/2
        positive[n // 2] = negative[n // 2] = 0.5
    forward = np.fft.ifft(spectrum * positive)
    backward = np.fft.ifft(spectrum * negative)
    unit = str(ds[x].attrs.get("units", "m"))
    return xr.Dataset({"forward": ("t", forward.real, {"units": unit}),
                       "backward": ("t", backward.real, {"units": unit})},
                      coords={"t": ds["t"]}, attrs=dict(ds.attrs))


def full_spectrum_peaks(ds: xr.Dataset, x: str | None = None, y: str | None = None,
                        max_peaks: int = 8, min_relative_height: float = 0.02,
                        vocabulary: str = "shaft") -> list[WhirlPeak]:
    """The ``max_peaks`` largest lines of the full spectrum, forward and backward, by
    descending amplitude, named as ``find_peaks`` names them (``vocabulary``: m·X + n·VC
    or the defect frequencies). A line must reach ``min_relative_height`` of the largest
    line of either side (a pure forward whirl has no backward lines, not its leakage
    named)."""
    x, y = orbit_pair(ds, x, y)
    parts = whirl_components(ds, x, y)
    found: list[WhirlPeak] = []
    for whirl in WHIRLS:
        if not np.any(parts[whirl].values):
            continue
        for peak in find_peaks(parts, whirl, max_peaks=max_peaks,
                               min_relative_height=min_relative_height,
                               vocabulary=vocabulary):
            fields = {**peak.__dict__, "direction": f"{x}+i{y}"}
            found.append(WhirlPeak(**fields, whirl=whirl))
    if not found:
        return []
    top = max(p.amplitude for p in found)
    kept = [p for p in found if p.amplitude >= min_relative_height * top]
    kept.sort(key=lambda p: -p.amplitude)
    return kept[:max_peaks]


UNNAMED_SEARCH = 40
"""Lines searched for the strongest unnamed ones (``unnamed_lines``)."""
UNNAMED_WHY = ("no m·X + n·VC (|m| ≤ 4, n ≤ 3) lies within 1.5 bins: the broadband part "
               "of a chaotic or quasi-periodic response (or a free vibration of the rotor on "
               "its balls), which no forcing of the model names")
"""Why a line of a full spectrum has no name."""


def unnamed_lines(ds: xr.Dataset, x: str | None = None, y: str | None = None,
                  count: int = 5, min_relative_height: float = 0.01) -> list[WhirlPeak]:
    """The ``count`` strongest lines of the full spectrum (among its ``UNNAMED_SEARCH``
    largest, each at least ``min_relative_height`` of the largest) that have no name: in a
    chaotic spectrum the lines a reader asks about first. ``UNNAMED_WHY`` says why they have
    none, ``unnamed_reason`` for one line."""
    peaks = full_spectrum_peaks(ds, x, y, max_peaks=UNNAMED_SEARCH,
                                min_relative_height=min_relative_height)
    return [p for p in peaks if p.label is None][:count]


def unnamed_reason(peak: Peak, ds: xr.Dataset) -> str | None:
    """A word on why ``peak`` has no name (None when it has one): below the record's
    resolution (under two bins, 2/T), or not a combination of the model's forcings
    (``UNNAMED_WHY``)."""
    if peak.label is not None:
        return None
    n = ds.sizes.get("t", 0)
    span = n * time_step(ds) if n > 1 else 0.0  # the record's length T: bins of 1/T
    if span > 0 and peak.frequency_hz < 2.0 / span:
        return (f"below two bins of the {span:.4g} s record (a drift or a beat slower than "
                "the record resolves)")
    return UNNAMED_WHY


__all__ = ["UNNAMED_WHY", "WHIRLS", "WhirlPeak", "full_spectrum", "full_spectrum_peaks",
           "orbit_pair", "unnamed_lines", "unnamed_reason", "whirl_components"]
