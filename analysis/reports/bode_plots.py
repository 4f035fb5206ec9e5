"""Bode and polar plots of the 1X response along a sweep (``analysis.sweeps.diagram``): the
amplitude and phase lag of each displacement at the shaft frequency against the swept
parameter, as ``analysis.signal.phasor`` records them at every value."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.errors import InputError
from analysis.model import balls_text
from analysis.reports import canvas as plt
from analysis.reports.plots import grid_axis, unit_scale


def phasor_variables(ds: xr.Dataset, variables: list[str] | tuple[str, ...] | None = None,
                     path: str = "the result") -> tuple[str, ...]:
    """The variables of a diagram with a 1X record (``amplitude1x_<v>``, ``phase1x_<v>``):
    ``variables`` (each checked), or all recorded. ``InputError`` for a result that is no
    diagram or has no 1X record (a diagram written before it, or of a model without a
    shaft)."""
    if ds.attrs.get("kind") != "diagram":
        kind = ds.attrs.get("kind")
        what = (f"kind {str(kind)[:60]!r}" if kind is not None else "a run" if "t" in ds.dims
                else "it has no kind attribute")
        raise InputError(f"result file: '{path}' is not a sweep's diagram ({what}); Bode and "
                         "polar plots need a `bearingdyn sweep` result")
    recorded = tuple(str(v)[len("amplitude1x_"):] for v in ds.data_vars
                     if str(v).startswith("amplitude1x_"))
    if not recorded or not any(np.isfinite(ds[f"amplitude1x_{v}"].values).any()
                               for v in recorded):
        raise InputError(f"result file: '{path}' holds no 1X amplitude and phase "
                         "(a diagram written before they were recorded, or of a model "
                         "without a shaft); run the sweep again")
    for v in variables or ():
        if v not in recorded:
            raise InputError(f"var: no 1X record of {v!r} in this diagram; recorded: "
                             f"{', '.join(recorded)}", field="var")
    if variables:
        return tuple(variables)
    largest = {v: float(np.nanmax(ds[f"amplitude1x_{v}"].values)) for v in recorded}
    top = max(largest.values())
    return tuple(v for v in recorded if largest[v] > 1e-9 * top)  # not a coordinate at rest


def _amplitude_unit(ds: xr.Dataset, variables) -> tuple[float, str]:
    """(factor, unit) of the 1X amplitudes: µm for metres below a millimetre (the rotors),
    else the SI unit itself (a Duffing oscillator's metres)."""
    unit = str(ds[f"amplitude1x_{variables[0]}"].attrs.get("units", "m"))
    largest = max(float(np.nanmax(ds[f"amplitude1x_{v}"].values)) for v in variables)
    return unit_scale(unit) if largest < 1e-3 else (1.0, unit)


PERIOD_TOLERANCE = 1e-3
"""A value's response is periodic when its section samples repeat after n ≤ ``MAX_PERIOD``
within this fraction of the diagram's largest section spread (``classify``'s tolerance)."""
MAX_PERIOD = 16


def periodic_values(ds: xr.Dataset, d: int) -> np.ndarray:
    """Per value of the swept parameter (the diagram's order), whether the response of
    direction ``d`` is periodic: its section samples (every state variable of the diagram
    with a ``k`` axis) repeat with a period n ≤ ``MAX_PERIOD``
    (``analysis.stability.classify.repeat_period``). A value whose 1X amplitude and phase
    are not those of a periodic response (quasi-periodic, chaotic) is False; so is one
    without samples."""
    from analysis.stability.classify import repeat_period

    param = ds.attrs["param"]
    names = [str(v) for v in ds.data_vars if ds[v].dims == ("direction", param, "k")
             and str(ds[v].attrs.get("units", "")) in ("m", "rad")]
    if not names:
        return np.ones(ds.sizes[param], dtype=bool)
    samples = np.stack([ds[v].isel(direction=d).values for v in names], axis=-1)
    finite = np.isfinite(samples)
    spread = max((float(np.max(column[ok]) - np.min(column[ok]))  # over the whole sweep
                  for column, ok in zip(np.moveaxis(samples, -1, 0), np.moveaxis(finite, -1, 0),
                                        strict=True) if ok.any()), default=0.0)
    size = max(spread, 1e-300)
    out = np.zeros(samples.shape[0], dtype=bool)
    for i, points in enumerate(samples):
        points = points[np.all(np.isfinite(points), axis=1)]
        out[i] = repeat_period(points, size, PERIOD_TOLERANCE, MAX_PERIOD) is not None
    return out


def _ordered(ds: xr.Dataset, param: str, d: int, v: str):
    """(parameter values, amplitude, lag unwrapped along the sweep in rad, periodic) of
    direction ``d``, in increasing parameter, NaN values dropped (``periodic``:
    ``periodic_values``)."""
    values = ds[param].values.astype(float)
    amp = ds[f"amplitude1x_{v}"].isel(direction=d).values
    lag = ds[f"phase1x_{v}"].isel(direction=d).values
    periodic = periodic_values(ds, d)
    order = np.argsort(values)
    values, amp, lag, periodic = values[order], amp[order], lag[order], periodic[order]
    keep = np.isfinite(amp) & np.isfinite(lag)
    values, amp, lag, periodic = values[keep], amp[keep], lag[keep], periodic[keep]
    if lag.size:
        lag = np.unwrap(lag)
        lag -= 2 * math.pi * math.floor(lag[0] / (2 * math.pi))  # the first in [0, 2π)
    return values, amp, lag, periodic


NOT_PERIODIC = "not periodic (no period ≤ 16 on the section): 1X is one line of many"
"""The legend of the marks on values whose response is not periodic."""


def _mark_not_periodic(ax, x, y, periodic, marked: list) -> None:
    """Grey rings on the points of ``ax`` whose response is not periodic; the legend entry
    once (``marked`` holds whether it was given)."""
    if np.any(~periodic):
        ax.plot(x[~periodic], y[~periodic], "o", ms=7, mfc="none", mec="0.35", mew=1.0,
                label=None if marked else NOT_PERIODIC)
        marked.append(True)


def _title(ds: xr.Dataset, what: str) -> str:
    structure = balls_text(ds.attrs, "$N_b$", "")
    return (f"{ds.attrs['model']}" + (f", {structure}" if structure else "")
            + f": {what} of the 1X response along {ds.attrs['param']}")


def bode_figure(ds: xr.Dataset, variables: list[str] | tuple[str, ...] | None = None,
                path: str = "the result") -> Figure:
    """Bode plot of a diagram: 1X amplitude (µm for m below a millimetre) and phase lag
    (degrees after the shaft's zero angle, unwrapped along the sweep) of ``variables``
    (default: every
    recorded displacement that moves) against the swept parameter; up- and down-sweeps
    dashed apart; values whose response is not periodic ringed (``periodic_values``: their
    1X is one line of a broader spectrum, not the response)."""
    variables = phasor_variables(ds, variables, path)
    param = ds.attrs["param"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True,
                                      layout="constrained")
    factor, unit = _amplitude_unit(ds, variables)
    marked: list = []
    for i, v in enumerate(variables):
        for d, direction in enumerate(ds.direction.values):
            values, amp, lag, periodic = _ordered(ds, param, d, v)
            style = dict(color=f"C{i}", ls="-" if d == 0 else "--", lw=1.3, marker=".",
                         ms=3)
            label = v + (f" (sweep {direction})" if ds.sizes["direction"] > 1 else "")
            top.plot(values, amp * factor, label=label, **style)
            bottom.plot(values, np.degrees(lag), **style)
            _mark_not_periodic(top, values, amp * factor, periodic, marked)
            _mark_not_periodic(bottom, values, np.degrees(lag), periodic, [True])
    top.set_ylabel(f"1X amplitude ({unit})")
    bottom.set_ylabel("1X phase lag (degrees)")
    grid_axis(bottom.xaxis, ds, param)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    bottom.yaxis.set_major_locator(_degree_locator())
    top.legend(fontsize=8)
    fig.suptitle(_title(ds, "Bode plot"), fontsize=10)
    return plt.finish(fig, ds)


def _degree_locator():
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(nbins=8, steps=[1, 1.5, 3, 4.5, 9, 10])


def polar_figure(ds: xr.Dataset, variables: list[str] | tuple[str, ...] | None = None,
                 path: str = "the result") -> Figure:
    """Polar plot of a diagram: the 1X phasor of each of ``variables`` (radius: amplitude
    in µm for m; angle: the phase lag, drawn against the rotation, clockwise from the
    top), one panel per variable, with the first, last and largest points named by their
    parameter value."""
    variables = phasor_variables(ds, variables, path)
    param = ds.attrs["param"]
    unit_name = ds[param].attrs.get("units", "") if param in ds else ""
    fig = plt.subplots(figsize=(5.2 * len(variables), 5.6), layout="constrained")[0]
    fig.clear()
    for i, v in enumerate(variables):
        ax = fig.add_subplot(1, len(variables), i + 1, projection="polar")
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)  # lag grows clockwise: against a counter-clockwise shaft
        ax.set_rlabel_position(200)
        factor, unit = _amplitude_unit(ds, (v,))
        marked: list = []
        for d, direction in enumerate(ds.direction.values):
            values, amp, lag, periodic = _ordered(ds, param, d, v)
            if not values.size:
                continue
            ax.plot(lag, amp * factor, ".-", lw=1.0, ms=3, color=f"C{d}",
                    label=f"sweep {direction}")
            _mark_not_periodic(ax, lag, amp * factor, periodic, marked)
            for j in sorted({0, values.size - 1, int(np.argmax(amp))}):
                ax.annotate(f"{values[j]:.6g}", (lag[j], amp[j] * factor), xytext=(4, 4),
                            textcoords="offset points", fontsize=7)
        ax.set_title(f"1X of {v}: radius amplitude ({unit}), angle phase lag", fontsize=9)
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(-0.1, -0.12))
    fig.suptitle(_title(ds, "polar plot") + (f"; points named by {param}"
                                             + (f" ({unit_name})" if unit_name else "")),
                 fontsize=10)
    return plt.finish(fig, ds)


__all__ = ["bode_figure", "periodic_values", "phasor_variables", "polar_figure"]
