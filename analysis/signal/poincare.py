"""Stroboscopic Poincaré sections of simulated responses.

The state (every state variable of the run: ``x``, ``y`` in m, ``vx``, ``vy`` in m/s for the
paper's rotor; ``x_rotor`` … ``vy_housing``, tilts ``tx`` in rad, …) on the uniform time
coordinate ``t`` (s) is sampled once per period of a section, the frequencies (Hz) being read
from the dataset attrs:

- ``shaft``: 1/``shaft_hz``;
- ``cage``, ``vc``: the cage or varying-compliance period of the model's bearing (the first
  bearing of a model with several), 1/``cage_hz``, 1/``vc_hz``;
- ``cage[left]``, ``vc[left]``: those of the bearing named ``left`` (attrs ``cage_hz_left``,
  ``vc_hz_left``);
- ``param:NAME``: the value (s) of the run's parameter NAME, for a model forced at a period
  of its own (the Mathieu equation's ``param:forcing_period``).

A period-1 response gives one point, a period-2 (X/2 subharmonic) response two, and so on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.forcing import SECTION
from analysis.integrate.speed_profile import refuse_profile
from analysis.provenance import cage_frequencies, state_names, vc_frequencies

SECTIONS = SECTION.kinds
"""The sections every model with a shaft and a bearing has (see ``SECTION_SYNTAX``)."""
SECTION_SYNTAX = SECTION.syntax

_DEFAULT_UNITS = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s"}

# A section time within this fraction of dt of a sample time uses the sample itself.
_SNAP_FRACTION = 1e-9


def parse_section(section: str) -> tuple[str, str | None]:
    """(kind, bearing or parameter name) of a section's text; ``InputError`` when it is not
    valid syntax (checked before any file is read; the grammar of
    ``analysis.forcing.SECTION``)."""
    forcing = SECTION.parse(section)
    return forcing.kind, forcing.name


def _section_frequency(attrs: Mapping, section: str) -> tuple[str, float]:
    """(attr that holds it, frequency Hz) of ``section``; raises InputError for a section
    that is not valid syntax or that the run does not have."""
    text = str(section).strip()
    kind, bearing = parse_section(text)
    if kind == "param":
        name = bearing
        if name not in attrs:
            raise InputError(f"{name}: not a parameter of this run (needed by the "
                             f"'{text}' section)")
        value = float(attrs[name])
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{name}: must be a positive period in s for the '{text}' "
                             f"section, got {attrs[name]!r}")
        return name, 1.0 / value
    if kind == "shaft":
        key = "shaft_hz"
        if key not in attrs:
            raise InputError(f"{key}: missing from the dataset attrs (needed by the "
                             f"'{text}' section)")
        frequency = float(attrs[key])
    else:
        table = (vc_frequencies if kind == "vc" else cage_frequencies)(attrs)
        several = "" not in table and len(table) > 0
        if bearing is None:
            if several:
                bearing = next(iter(table))
            key = f"{kind}_hz" + (f"_{bearing}" if several else "")
            if key not in attrs:
                raise InputError(f"{key}: missing from the dataset attrs (needed by the "
                                 f"'{text}' section)")
            frequency = float(attrs[key])
        else:
            key = f"{kind}_hz_{bearing}"
            if key in attrs:
                frequency = float(attrs[key])
            elif not several and f"{kind}_hz" in attrs and (
                    f"n_balls_{bearing}" in attrs or attrs.get("bearing_name") == bearing):
                key = f"{kind}_hz"  # the only bearing, named
                frequency = float(attrs[key])
            else:
                names = ", ".join(b for b in table if b) or "none with several"
                raise InputError(f"section: no bearing '{bearing}' in this run (bearings: "
                                 f"{names}), got {section!r}")
    if not (math.isfinite(frequency) and frequency > 0):
        raise InputError(f"{key}: must be a positive frequency in Hz, got {attrs[key]!r}"
                         + (" (a model without a shaft: use param:NAME)" if key == "shaft_hz"
                            else " (a model without bearings has no cage or VC period)"
                            if not frequency else ""))
    return key, frequency


def period_of(attrs: Mapping, section: str) -> float:
    """The period (s) of ``section`` from a run's attrs (or any mapping holding the same
    keys: the frequencies of ``Frequencies.as_dict`` and the parameter values)."""
    return 1.0 / _section_frequency(attrs, section)[1]


def section_period(ds: xr.Dataset, section: str) -> float:
    """The period (s) of ``section`` (see the module docstring) from ``ds.attrs``."""
    return period_of(ds.attrs, section)


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
    [t[0], t[-1]] gives one point. Every state variable of the run is kept (``state_names``
    attr; ``x``, ``y``, ``vx``, ``vy`` for files without it). Between samples the state is
    interpolated with cubic Hermite splines: a coordinate (x, y, tx, x_rotor, …) with its
    velocity (vx, …) as derivative, a velocity (and a coordinate without one) with
    derivatives from ``numpy.gradient`` (second order, also at the ends). The x, y
    interpolation error is
    O(dt⁴ω⁴), the vx, vy error O(dt³ω³) relative to the amplitude (ω in rad/s; about 2e-12 and
    2e-9 for 83 Hz at dt = 1e-5 s). A t_k within 1e-9·dt of a sample time takes that sample
    exactly.

    Returns a Dataset along dimension ``k`` (coordinate: the integer k of t_k) with coordinate
    ``t`` (s, the section times t_k) and the state variables (x, y (m), vx, vy (m/s), …, with
    their attrs); attrs are those of ``ds`` plus ``section``, ``section_period_s`` and
    ``phase``.
    """
    refuse_profile(ds.attrs, "poincare")  # a run-up: no fixed period
    period = section_period(ds, section)
    phase = float(phase)
    if not 0.0 <= phase < 1.0:
        raise InputError(f"phase: must be a fraction of the period in [0, 1), got {phase!r}")
    names = state_names(ds)
    missing = [name for name in names if name not in ds.data_vars]
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

    coordinates = [n for n in names if f"v{n}" in names]
    others = [n for n in names if n not in coordinates]
    position = np.column_stack([ds[n].values for n in coordinates]).astype(float) \
        if coordinates else np.empty((t.size, 0))
    velocity = np.column_stack([ds[f"v{n}"].values for n in coordinates]).astype(float) \
        if coordinates else np.empty((t.size, 0))
    rest = np.column_stack([ds[n].values for n in others]).astype(float)
    t_eval = np.clip(t_k, t[0], t[-1])
    i = np.clip(np.searchsorted(t, t_eval, side="right") - 1, 0, t.size - 2)
    pos_k = _hermite(t, position, velocity, i, t_eval)
    rest_k = _hermite(t, rest, np.stack([_gradient_at(t, rest, i),
                                         _gradient_at(t, rest, i + 1)]), i, t_eval)

    nearest = np.clip(np.searchsorted(t, t_k), 1, t.size - 1)
    nearest = np.where(np.abs(t[nearest - 1] - t_k) <= np.abs(t[nearest] - t_k),
                       nearest - 1, nearest)
    on_sample = np.abs(t[nearest] - t_k) <= snap
    pos_k[on_sample] = position[nearest[on_sample]]
    rest_k[on_sample] = rest[nearest[on_sample]]
    columns = {n: pos_k[:, j] for j, n in enumerate(coordinates)}
    columns.update({n: rest_k[:, j] for j, n in enumerate(others)})

    def variable(name: str) -> tuple[str, np.ndarray, dict[str, str]]:
        var_attrs = {key: str(value) for key, value in ds[name].attrs.items()}
        var_attrs["units"] = str(ds[name].attrs.get("units", _DEFAULT_UNITS.get(name, "")))
        return ("k", columns[name], var_attrs)

    attrs = dict(ds.attrs)
    attrs.update(section=str(section), section_period_s=period, phase=phase)
    return xr.Dataset(
        {name: variable(name) for name in names},
        coords={"k": ("k", k), "t": ("k", t_k, {"units": "s"})},
        attrs=attrs,
    )
