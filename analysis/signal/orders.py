"""Order tracking: a run resampled in shaft angle, and its spectrum in orders.

In a run-up (a run whose speed follows a profile, ``analysis.integrate.speed_profile``) every
line that turns with the shaft (X, 2X, VC, VC±X, the defect frequencies) sweeps in
frequency, but keeps its *order*, its number of cycles per shaft revolution. Sampling the
record at equal steps of the shaft angle φ(t) = ∫ω dt instead of equal steps of time makes
those lines stand still: the spectrum of the resampled record has them at fixed orders.

Resampling: the angle grid φ_k = φ(t_0) + k·2π/S (S samples per revolution) is mapped to
times t_k = φ⁻¹(φ_k), exactly from the profile (``SpeedProfile.time_at_angle``: the angle is
piecewise quadratic in t), and the record is interpolated at t_k by a cubic spline through
its samples (error O((ω_max·dt)⁴) of the amplitude at the highest order kept). The order
spectrum is the Hann amplitude spectrum of the resampled record (the scaling of
``analysis.signal.spectrum.amplitude_spectrum``: a line of amplitude A shows height A), over
orders in bins of 1/(revolutions in the record). A constant-speed run can be order-tracked
too (φ = 2π·X·t): its order spectrum is its spectrum divided by X.

Named order lines: the combinations m·X + n·VC (named by
``analysis.signal.spectrum.frequency_names``) and the defect frequencies FTF, BPFO (= VC
with a stationary outer race), BPFI and BSF of each bearing, each at the order its frequency
has at t = 0 (the run's attrs): every characteristic frequency is proportional to the speed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.interpolate
import scipy.signal
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.integrate.speed_profile import SpeedProfile, profile_of
from analysis.provenance import displacement_names, vc_frequencies
from analysis.signal.spectrum import FAULT_NAMES, fault_frequencies, frequency_names


@dataclass(frozen=True)
class OrderLine:
    """A named line that turns with the shaft: ``name`` (X, 2X, VC, VC-X, BPFI, …) at
    ``order`` cycles per revolution; ``kind`` is ``"shaft"`` (m·X + n·VC) or ``"fault"``."""

    name: str
    order: float
    kind: str = "shaft"

    def as_dict(self) -> dict:
        return {"name": self.name, "order": self.order, "kind": self.kind}


def shaft_order_base(attrs: Mapping[str, Any]) -> float:
    """The shaft frequency X (Hz) at t = 0 of a run (``shaft_hz``), which every order is
    relative to; ``InputError`` for a run without a turning shaft."""
    shaft = float(attrs.get("shaft_hz", 0.0))
    if not shaft > 0:
        raise InputError("orders: the run has no turning shaft (shaft_hz 0); orders are "
                         "cycles per shaft revolution")
    return shaft


def order_lines(attrs: Mapping[str, Any], max_order: float = 12.0, max_shaft_order: int = 3,
                max_vc_order: int = 2, faults: bool = True) -> list[OrderLine]:
    """The named lines of a run (its attrs) up to ``max_order`` (cycles/rev): the shaft
    harmonics m·X (m ≤ ``max_shaft_order``), each VC harmonic n·VC (n ≤
    ``max_vc_order``) and its sidebands n·VC ± X (names as in spectra: X, 2X, 3X, VC,
    VC-X, VC+X, 2VC, 2VC-X, VC[left]…), then with ``faults`` each bearing's FTF, BPFI and
    BSF (BPFO is VC for a stationary outer race: named VC; BPFO itself where there is no VC,
    a measured record's bearing), by increasing order."""
    shaft = shaft_order_base(attrs)
    vcs = vc_frequencies(attrs)
    lines: dict[str, OrderLine] = {}
    vc_list = [(b, f) for b, f in vcs.items() if f > 0] or [("", 0.0)]
    for bearing, vc in vc_list:
        for n in range(max_vc_order + 1 if vc > 0 else 1):
            for m in range(-max_shaft_order, max_shaft_order + 1) if n == 0 else (-1, 0, 1):
                f = m * shaft + n * vc
                if not f > 0 or f / shaft > max_order:
                    continue
                names = frequency_names(f, shaft, {bearing: vc} if vc > 0 else 0.0,
                                        tol_hz=1e-9 * f, max_shaft_order=max_shaft_order,
                                        max_vc_order=max_vc_order)
                if names and names[0][0] not in lines:
                    lines[names[0][0]] = OrderLine(names[0][0], f / shaft)
    if faults:
        for bearing, table in fault_frequencies(dict(attrs)).items():
            for key in FAULT_NAMES:
                f = table.get(key, 0.0)
                if (key == "BPFO" and vcs) or not f > 0 or f / shaft > max_order:
                    continue
                name = f"{key}[{bearing}]" if bearing else key
                lines.setdefault(name, OrderLine(name, f / shaft, "fault"))
    return sorted(lines.values(), key=lambda line: line.order)


def shaft_angle(ds: xr.Dataset) -> np.ndarray:
    """The shaft angle φ (rad) at each sample of a run: ∫ω dt of its speed profile, or
    2π·X·t at constant speed (t from the run's start at t = 0)."""
    t = np.asarray(ds["t"].values, dtype=float)
    profile = profile_of(ds.attrs)
    if profile is not None:
        return profile.shaft_angle(t, _duration(ds))
    return 2 * math.pi * shaft_order_base(ds.attrs) * t


def _duration(ds: xr.Dataset) -> float:
    return float(ds.attrs.get("duration", float(ds["t"].values[-1])))


def _profile_or_constant(ds: xr.Dataset) -> SpeedProfile:
    profile = profile_of(ds.attrs)
    if profile is not None:
        return profile
    return SpeedProfile("ramp", (float(ds.attrs.get("speed_rpm", 0.0)),) * 2)


def default_samples_per_rev(ds: xr.Dataset) -> int:
    """Samples per revolution of the angle grid: as many as the record has per revolution
    at its highest speed (even, >= 8), so no part of the record is sampled more coarsely
    in angle than it was in time."""
    t = np.asarray(ds["t"].values, dtype=float)
    dt = (t[-1] - t[0]) / (t.size - 1)
    profile = _profile_or_constant(ds)
    top = max(profile.rpm) / 60.0  # Hz
    return max(8, 2 * int(1.0 / (dt * top) // 2))


MAX_ANGLE_SAMPLES = 50_000_000
"""The most samples of an angle grid (400 MB of doubles)."""


def check_samples_per_rev(ds: xr.Dataset, samples_per_rev: int | None = None
                          ) -> tuple[int, int, np.ndarray]:
    """``(samples per revolution, samples of the angle grid, shaft angle)`` of the run
    ``ds``, judged before the grid is made: ``samples_per_rev`` (None: the default) an
    integer >= 4, and the grid of at least 16 and at most ``MAX_ANGLE_SAMPLES`` samples."""
    samples_per_rev = default_samples_per_rev(ds) if samples_per_rev is None \
        else samples_per_rev
    check_count("samples_per_rev", samples_per_rev, 4)
    phi = shaft_angle(ds)
    turns = (phi[-1] - phi[0]) / (2 * math.pi)
    count = math.floor((phi[-1] - phi[0]) / (2 * math.pi / samples_per_rev) * (1 + 1e-12)) + 1
    if count < 16:
        raise InputError(f"orders: the record holds {turns:.3g} shaft revolutions; order "
                         "tracking needs several")
    if count > MAX_ANGLE_SAMPLES:
        most = max(4, int(MAX_ANGLE_SAMPLES // max(turns, 1e-300)))
        raise InputError(f"samples_per_rev: at most {most} over the record's {turns:.4g} "
                         f"revolutions ({MAX_ANGLE_SAMPLES:.0e} angle samples in all), got "
                         f"{samples_per_rev}", field="samples_per_rev")
    return int(samples_per_rev), count, phi


def angle_resample(ds: xr.Dataset, var: str | None = None,
                   samples_per_rev: int | None = None) -> xr.DataArray:
    """``ds[var]`` (default: the first displacement) at equal steps of the shaft angle:
    ``samples_per_rev`` per revolution (default: ``default_samples_per_rev``) from the
    record's first sample to its last. Coordinate ``revolution`` (shaft turns since t = 0)
    and, along it, the times ``t`` (s) of the samples."""
    var = displacement_names(ds)[0] if var is None else var
    if var not in ds.data_vars:
        raise InputError(f"var: no state variable {var!r} in this run; variables: "
                         f"{', '.join(map(str, ds.data_vars))}", field="var")
    samples_per_rev, count, phi = check_samples_per_rev(ds, samples_per_rev)
    t = np.asarray(ds["t"].values, dtype=float)
    values = np.asarray(ds[var].values, dtype=float)
    step = 2 * math.pi / samples_per_rev
    grid = phi[0] + step * np.arange(count)
    profile = profile_of(ds.attrs)
    if profile is not None:
        times = profile.time_at_angle(grid, _duration(ds))
    else:
        times = grid / (2 * math.pi * shaft_order_base(ds.attrs))
    times = np.clip(times, t[0], t[-1])
    resampled = scipy.interpolate.CubicSpline(t, values)(times)
    attrs = dict(ds.attrs)
    attrs.update(units=str(ds[var].attrs.get("units", "")), samples_per_rev=samples_per_rev)
    return xr.DataArray(resampled, dims="revolution",
                        coords={"revolution": ("revolution", grid / (2 * math.pi),
                                               {"units": "rev"}),
                                "t": ("revolution", times, {"units": "s"})},
                        name=var, attrs=attrs)


def amplitude(values: np.ndarray, window: str = "hann") -> np.ndarray:
    """The one-sided amplitude spectrum of ``values`` as ``amplitude_spectrum`` scales it:
    mean removed, ``window`` applied, 2·|rfft|/Σw (DC and Nyquist not doubled). Along the
    last axis."""
    values = np.asarray(values, dtype=float)
    n = values.shape[-1]
    w = scipy.signal.get_window(window, n)
    centred = values - values.mean(axis=-1, keepdims=True)
    out = 2.0 * np.abs(np.fft.rfft(centred * w, axis=-1)) / w.sum()
    out[..., 0] /= 2.0
    if n % 2 == 0:
        out[..., -1] /= 2.0
    return out


def order_spectrum(ds: xr.Dataset, var: str | None = None,
                   samples_per_rev: int | None = None) -> xr.DataArray:
    """The order spectrum of ``ds[var]``: the Hann amplitude spectrum (unit of the
    variable) of the record resampled in shaft angle (``angle_resample``), over
    ``order`` (cycles per revolution; bin 1/revolutions of the record). A line turning
    with the shaft stands at its order however the speed changed. attrs: the run's, the
    ``order_bin`` and the named ``lines`` as text ``name=order`` (``order_lines``)."""
    resampled = angle_resample(ds, var, samples_per_rev)
    spr = int(resampled.attrs["samples_per_rev"])
    spectrum = amplitude(resampled.values)
    order = np.fft.rfftfreq(resampled.size, d=1.0 / spr)
    attrs = dict(resampled.attrs)
    attrs.update(order_bin=float(order[1]), variable=str(resampled.name))
    return xr.DataArray(spectrum, dims="order",
                        coords={"order": ("order", order, {"units": "cycles/rev"})},
                        name=f"{resampled.name}_order_amplitude", attrs=attrs)


@dataclass(frozen=True)
class OrderPeak:
    """A peak of an order spectrum: its ``order``, ``amplitude`` (unit of the variable)
    and the named line within ``tolerance`` orders (None: unnamed), with the named line's
    own order ``named_order``, the spectrum's ``bin`` (orders) and every other name within
    the tolerance (``also``)."""

    order: float
    amplitude: float
    name: str | None
    named_order: float | None = None
    bin: float = 0.0
    also: tuple[str, ...] = ()

    @property
    def in_its_bin(self) -> bool:
        """The peak is within half a bin of the named line's order: the name is the line's,
        not only the nearest combination."""
        return self.named_order is not None and \
            bool(abs(self.order - self.named_order) <= 0.5 * self.bin)

    @property
    def text(self) -> str:
        """The name as printed: ``VC+2X``, or ``within a bin of VC+2X (5.189)`` for a
        peak off its line by more than half a bin (the record cannot tell them apart, nor
        say they are one), with ``or`` and the other names within the tolerance."""
        if self.name is None:
            return ""
        names = " or ".join((self.name, *self.also))
        if self.in_its_bin or self.named_order is None:
            return names
        return f"within a bin of {names} ({self.named_order:.4g})"

    def as_dict(self) -> dict:
        return {"order": self.order, "amplitude": self.amplitude, "name": self.name,
                "named_order": self.named_order, "also": list(self.also),
                "in_its_bin": self.in_its_bin, "text": self.text}


def order_peaks(spectrum: xr.DataArray, max_peaks: int = 8,
                min_relative_height: float = 0.02,
                tolerance_bins: float = 1.5) -> list[OrderPeak]:
    """The ``max_peaks`` largest peaks of an ``order_spectrum`` (height >=
    ``min_relative_height`` × the largest; the order refined between bins by a parabola
    through the log-amplitudes, as ``find_peaks`` refines a frequency), by decreasing
    amplitude (that of the highest bin), each named as a
    spectrum's peak is (``frequency_names``: m·X + n·VC, |m| ≤ 4, n ≤ 3, the lowest order
    first) within ``tolerance_bins`` order bins, else by the nearest defect order (FTF,
    BPFI, BSF: ``order_lines``) within them."""
    values = np.asarray(spectrum.values)
    orders = np.asarray(spectrum["order"].values)
    search = values[1:]
    if not search.size or not search.max() > 0:
        return []
    found, _ = scipy.signal.find_peaks(search, height=min_relative_height * search.max())
    found = found[np.argsort(-search[found])][:max_peaks] + 1
    shaft = shaft_order_base(spectrum.attrs)
    vcs = vc_frequencies(spectrum.attrs)
    faults = [line for line in order_lines(spectrum.attrs, max_order=float(orders[-1]))
              if line.kind == "fault"]
    step = float(spectrum.attrs["order_bin"])
    tol = tolerance_bins * step
    out = []
    for k in found:
        order = float(orders[k])
        if 0 < k < values.size - 1 and np.all(values[k - 1:k + 2] > 0):
            a, b, c = np.log(values[k - 1:k + 2])  # refined between bins as find_peaks does
            shift = 0.5 * (a - c) / (a - 2 * b + c)
            order += step * shift if abs(shift) <= 0.5 else 0.0
        names = frequency_names(order * shaft, shaft, vcs, tol_hz=tol * shaft)
        if names:
            (name, m, n, bearing), also = names[0], tuple(other[0] for other in names[1:])
            vc = vcs.get(bearing or "", 0.0)
            named: float | None = (m * shaft + n * vc) / shaft
        else:
            near = sorted((line for line in faults if abs(line.order - order) <= tol),
                          key=lambda line: abs(line.order - order))
            name, named = (near[0].name, near[0].order) if near else (None, None)
            also = tuple(line.name for line in near[1:])
        out.append(OrderPeak(order, float(values[k]), name, named, step, also))
    return out
