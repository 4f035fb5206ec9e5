"""Stroboscopic Poincaré sections of simulated responses.

The state (``x``, ``y`` in m, ``vx``, ``vy`` in m/s) on the uniform time coordinate ``t`` (s)
is sampled once per period of the shaft (1/``shaft_hz``), the cage (1/``cage_hz``) or the
varying compliance (1/``vc_hz``), the frequencies (Hz) being read from the dataset attrs.
A period-1 response gives one point, a period-2 (X/2 subharmonic) response two, and so on.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from analysis.errors import InputError

SECTIONS = ("shaft", "cage", "vc")

_FREQUENCY_ATTRS = {"shaft": "shaft_hz", "cage": "cage_hz", "vc": "vc_hz"}
_DEFAULT_UNITS = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s"}

# A section time within this fraction of dt of a sample time uses the sample itself.
_SNAP_FRACTION = 1e-9


def section_period(ds: xr.Dataset, section: str) -> float:
    """The period (s) of ``section``: 1/shaft_hz, 1/cage_hz or 1/vc_hz from ``ds.attrs``."""
    if section not in _FREQUENCY_ATTRS:
        raise InputError(f"section: must be one of {', '.join(map(repr, SECTIONS))}, "
                         f"got {section!r}")
    key = _FREQUENCY_ATTRS[section]
    if key not in ds.attrs:
        raise InputError(f"{key}: missing from the dataset attrs (needed by the "
                         f"'{section}' section)")
    frequency = float(ds.attrs[key])
    if not (math.isfinite(frequency) and frequency > 0):
        raise InputError(f"{key}: must be a positive frequency in Hz, got {ds.attrs[key]!r}")
    return 1.0 / frequency


def _gradient_at(t: np.ndarray, f: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``numpy.gradient(f, t, axis=0, edge_order=2)`` evaluated at the indices ``j`` only."""
    n = t.size
    out = np.empty((j.size, f.shape[1]))
    inner = (j > 0) & (j < n - 1)
    jj = j[inner]
    h0, h1 = (t[jj] - t[jj - 1])[:, None], (t[jj + 1] - t[jj])[:, None]
    out[inner] = (h0**2 * f[jj + 1] - h1**2 * f[jj - 1] + (h1**2 - h0**2) * f[jj]) / (
        h0 * h1 * (h0 + h1))
    for edge, window in ((0, slice(0, 3)), (n - 1, slice(n - 3, n))):
        at = j == edge
        if np.any(at):
            out[at] = np.gradient(f[window], t[window], axis=0, edge_order=2)[
                0 if edge == 0 else -1]
    return out


def _hermite(t: np.ndarray, y: np.ndarray, dy: np.ndarray, i: np.ndarray,
             t_eval: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolation on the intervals [t_i, t_i+1] (the formula of
    ``scipy.interpolate.CubicHermiteSpline``, evaluated only where needed). ``dy`` is the
    derivative at every sample (n × m) or at (i, i + 1) stacked (2 × k × m)."""
    h = (t[i + 1] - t[i])[:, None]
    s = ((t_eval - t[i]) / (t[i + 1] - t[i]))[:, None]
    d0, d1 = (dy[i], dy[i + 1]) if dy.ndim == 2 else (dy[0], dy[1])
    return ((2 * s**3 - 3 * s**2 + 1) * y[i] + (s**3 - 2 * s**2 + s) * h * d0
            + (-2 * s**3 + 3 * s**2) * y[i + 1] + (s**3 - s**2) * h * d1)


def poincare_section(ds: xr.Dataset, section: str = "shaft", phase: float = 0.0) -> xr.Dataset:
    """The state sampled at t_k = (phase + k)·T, T = :func:`section_period` (s).

    ``phase`` is a fraction of the period in [0, 1); every integer k with t_k in
    [t[0], t[-1]] gives one point. Between samples the state is interpolated with cubic
    Hermite splines: x and y with their derivatives vx and vy, vx and vy with derivatives from
    ``numpy.gradient`` (second order, also at the ends). The x, y interpolation error is
    O(dt⁴ω⁴), the vx, vy error O(dt³ω³) relative to the amplitude (ω in rad/s; about 2e-12 and
    2e-9 for 83 Hz at dt = 1e-5 s). A t_k within 1e-9·dt of a sample time takes that sample
    exactly.

    Returns a Dataset along dimension ``k`` (coordinate: the integer k of t_k) with coordinate
    ``t`` (s, the section times t_k) and variables x, y (m), vx, vy (m/s); attrs are those of
    ``ds`` plus ``section``, ``section_period_s`` and ``phase``.
    """
    period = section_period(ds, section)
    phase = float(phase)
    if not 0.0 <= phase < 1.0:
        raise InputError(f"phase: must be a fraction of the period in [0, 1), got {phase!r}")
    missing = [name for name in ("x", "y", "vx", "vy") if name not in ds.data_vars]
    if missing:
        raise InputError(f"dataset: missing variable(s) {', '.join(missing)}")
    t = np.asarray(ds["t"].values, dtype=float)
    if t.size < 2 or not np.all(np.diff(t) > 0):
        raise InputError("t: need at least 2 increasing time samples")
    dt = (t[-1] - t[0]) / (t.size - 1)
    snap = _SNAP_FRACTION * dt

    first = math.ceil((t[0] - snap) / period - phase)
    last = math.floor((t[-1] + snap) / period - phase)
    k = np.arange(first, last + 1)
    t_k = (phase + k) * period
    inside = (t_k >= t[0] - snap) & (t_k <= t[-1] + snap)
    k, t_k = k[inside], t_k[inside]

    position = np.column_stack([ds["x"].values, ds["y"].values]).astype(float)
    velocity = np.column_stack([ds["vx"].values, ds["vy"].values]).astype(float)
    t_eval = np.clip(t_k, t[0], t[-1])
    i = np.clip(np.searchsorted(t, t_eval, side="right") - 1, 0, t.size - 2)
    pos_k = _hermite(t, position, velocity, i, t_eval)
    vel_k = _hermite(t, velocity, np.stack([_gradient_at(t, velocity, i),
                                            _gradient_at(t, velocity, i + 1)]), i, t_eval)

    nearest = np.clip(np.searchsorted(t, t_k), 1, t.size - 1)
    nearest = np.where(np.abs(t[nearest - 1] - t_k) <= np.abs(t[nearest] - t_k),
                       nearest - 1, nearest)
    on_sample = np.abs(t[nearest] - t_k) <= snap
    pos_k[on_sample] = position[nearest[on_sample]]
    vel_k[on_sample] = velocity[nearest[on_sample]]

    def variable(name: str, values: np.ndarray) -> tuple[str, np.ndarray, dict[str, str]]:
        units = ds[name].attrs.get("units", _DEFAULT_UNITS[name])
        return ("k", values, {"units": str(units)})

    attrs = dict(ds.attrs)
    attrs.update(section=section, section_period_s=period, phase=phase)
    return xr.Dataset(
        {
            "x": variable("x", pos_k[:, 0]),
            "y": variable("y", pos_k[:, 1]),
            "vx": variable("vx", vel_k[:, 0]),
            "vy": variable("vy", vel_k[:, 1]),
        },
        coords={"k": ("k", k), "t": ("k", t_k, {"units": "s"})},
        attrs=attrs,
    )
