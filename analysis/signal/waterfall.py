"""Waterfall (cascade) of a run-up or coast-down: short-time spectra against speed.

A run whose speed follows a profile (``analysis.integrate.speed_profile``) is cut into
overlapping windows (``scipy.signal.ShortTimeFFT``, Hann window of ``window_s`` seconds, a
hop of a quarter window; only windows wholly inside the record). Each window's amplitude
spectrum is scaled as ``analysis.signal.spectrum.amplitude_spectrum`` scales a whole record
(2·|FFT|/Σw: a steady line of amplitude A shows height A) and stands at the window's mean
speed, n̄ = 60·Δφ/(2π·window), from the exact shaft angle φ(t) of the profile.

The named lines (``analysis.signal.orders.order_lines``: X, 2X, VC, VC±X, 2VC, FTF, BPFI,
BSF, …) are drawn at order × n̄/60 in each window: where the response holds that line, the
window's peak lies on it.

Window length: a line of order r sweeps r·dX/dt Hz per second, so in a window of T seconds
it smears over r·|dX/dt|·T Hz while the bins are 1/T wide. The default T = 1/√(r·|dX/dt|)
(r the order of VC+X, the highest of X, VC and their first combinations) makes the smear
of those lines one bin; it is kept between 16 samples and a quarter of the record.

Sweeps (``bearingdyn sweep``) store Poincaré points at each speed, not time records, so a
waterfall is drawn from a ramped run only.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.speed_profile import profile_of
from analysis.provenance import displacement_names
from analysis.signal.orders import order_lines

HOP_FRACTION = 0.25
"""Hop between windows, as a fraction of the window."""


def _time_step(t: np.ndarray) -> float:
    dt = (t[-1] - t[0]) / (t.size - 1)
    if not dt > 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=0.0):
        raise InputError("t: time samples must be increasing and uniformly spaced")
    return float(dt)


def default_window(ds: xr.Dataset) -> float:
    """The default window (s): the smear of the VC+X line (the highest order of X, VC and
    their first combinations; 2X without bearings) one bin wide, within [16 samples, a
    quarter of the record] (see the module)."""
    profile = profile_of(ds.attrs)
    t = np.asarray(ds["t"].values, dtype=float)
    span = float(t[-1] - t[0])
    times, rpm = profile.knots(float(ds.attrs.get("duration", t[-1])))
    rate = float(np.max(np.abs(np.diff(rpm) / np.diff(times)))) / 60.0  # Hz/s of X
    names = {line.name: line.order for line in order_lines(ds.attrs)}
    top = max((order for name, order in names.items() if name.startswith("VC")
               and name.endswith("+X")), default=2.0)
    window = 1.0 / math.sqrt(top * rate) if rate > 0 else span / 4
    return float(min(max(window, 16 * _time_step(t)), span / 4))


def waterfall(ds: xr.Dataset, var: str | None = None, window_s: float | None = None,
              max_order: float = 12.0) -> xr.Dataset:
    """Short-time amplitude spectra of ``ds[var]`` (default: the first displacement) of a
    run with a speed profile, and its named order lines.

    Returns a Dataset with ``amplitude`` (unit of the variable) over (``time``, ``frequency``)
    (s, Hz), along ``time`` the window's mean ``speed_rpm`` and shaft frequency ``shaft_hz``,
    and ``line_hz`` (``line``, ``time``): each named line's frequency in each window, with
    ``order`` along ``line`` (cycles per revolution). attrs: the run's, ``variable``,
    ``units``, ``window_s``, ``hop_s`` and ``bin_hz``. ``InputError`` for a run at
    constant speed (use a spectrum) or a window that does not fit."""
    profile = profile_of(ds.attrs)
    if profile is None:
        speed = ds.attrs.get("speed_rpm")
        at = f" ({float(speed):g} rpm)" if speed is not None else ""
        raise InputError(f"waterfall: the run is at a constant speed{at}; a waterfall needs "
                         "a run-up or coast-down: simulate with --speed-rpm A:B or a speed "
                         "table (sweeps keep no time records); for this run use `bearingdyn "
                         "spectrum`")
    var = displacement_names(ds)[0] if var is None else var
    if var not in ds.data_vars:
        raise InputError(f"var: no state variable {var!r} in this run; variables: "
                         f"{', '.join(map(str, ds.data_vars))}", field="var")
    t = np.asarray(ds["t"].values, dtype=float)
    dt = _time_step(t)
    span = float(t[-1] - t[0])
    window_s = default_window(ds) if window_s is None else float(window_s)
    if not (math.isfinite(window_s) and 8 * dt <= window_s <= span / 2):
        raise InputError(f"window: must be in [{8 * dt:g}, {span / 2:g}] s (8 samples to "
                         f"half the record), got {window_s!r}", field="window")
    size = round(window_s / dt)
    hop = max(1, round(HOP_FRACTION * size))
    win = scipy.signal.get_window("hann", size)
    stft = scipy.signal.ShortTimeFFT(win, hop, fs=1.0 / dt, fft_mode="onesided")
    values = np.asarray(ds[var].values, dtype=float)
    values = values - values.mean()
    first = stft.lower_border_end[1]
    last = stft.upper_border_begin(values.size)[1]
    if last <= first:
        raise InputError(f"window: {window_s:g} s leaves no whole window in the record",
                         field="window")
    spectra = stft.stft(values, p0=first, p1=last)  # (frequency, time)
    amp = 2.0 * np.abs(spectra) / win.sum()
    amp[0] /= 2.0
    if size % 2 == 0:
        amp[-1] /= 2.0
    centres = t[0] + stft.t(values.size, p0=first, p1=last)
    duration = float(ds.attrs.get("duration", t[-1]))
    start = profile.shaft_angle(centres - size * dt / 2, duration)
    end = profile.shaft_angle(centres + size * dt / 2, duration)
    shaft_hz = (end - start) / (2 * math.pi * size * dt)
    lines = order_lines(ds.attrs, max_order=max_order)
    frequency = stft.f
    attrs = dict(ds.attrs)
    attrs.update(variable=var, units=str(ds[var].attrs.get("units", "")),
                 window_s=size * dt, hop_s=hop * dt, bin_hz=float(frequency[1]))
    return xr.Dataset(
        {"amplitude": (("time", "frequency"), amp.T, {"units": attrs["units"]}),
         "speed_rpm": ("time", 60.0 * shaft_hz, {"units": "rpm"}),
         "shaft_hz": ("time", shaft_hz, {"units": "Hz"}),
         "line_hz": (("line", "time"),
                     np.array([line.order * shaft_hz for line in lines]).reshape(
                         len(lines), centres.size), {"units": "Hz"})},
        coords={"time": ("time", centres, {"units": "s"}),
                "frequency": ("frequency", frequency, {"units": "Hz"}),
                "line": ("line", [line.name for line in lines]),
                "order": ("line", [line.order for line in lines], {"units": "cycles/rev"}),
                "line_kind": ("line", [line.kind for line in lines])},
        attrs=attrs)


def line_tracks(wf: xr.Dataset) -> dict[str, dict[str, list[float]]]:
    """Each named line's amplitude in each window (the largest bin within one bin of the
    line; unit of the variable) against the window's speed: ``{name: {"order": …,
    "speed_rpm": […], "frequency_hz": […], "amplitude": […]}}``, the lines whose frequency
    stays inside the spectra."""
    amp = wf["amplitude"].values
    df = float(wf.attrs["bin_hz"])
    top = float(wf["frequency"].values[-1])
    out = {}
    for i, name in enumerate(wf["line"].values):
        f = wf["line_hz"].values[i]
        if not np.all(f < top - df):
            continue
        k = np.rint(f / df).astype(int)
        rows = np.arange(amp.shape[0])
        near = np.max(np.stack([amp[rows, np.clip(k + s, 0, amp.shape[1] - 1)]
                                for s in (-1, 0, 1)]), axis=0)
        out[str(name)] = {"order": float(wf["order"].values[i]),
                          "speed_rpm": wf["speed_rpm"].values.tolist(),
                          "frequency_hz": f.tolist(), "amplitude": near.tolist()}
    return out

