"""Matplotlib figures. Functions return figures; saving is the caller's business.

The figures are made without pyplot (``analysis.reports.canvas``: each on its own Agg
canvas), so importing this module or drawing leaves matplotlib's backend as it is (a
notebook's inline backend, a script's choice) and needs no display."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.errors import InputError
from analysis.forcing import run_period_parameter
from analysis.model import balls_text
from analysis.provenance import (
    as_run,
    check_ours,
    displacement_names,
    state_names,
    vc_frequencies,
)
from analysis.reports import canvas as plt  # pyplot's subplots and close, without pyplot
from analysis.reports.labels import default_partner, display_label, f_max_of, series_f_max
from analysis.signal.poincare import poincare_section, section_period
from analysis.signal.spectrum import Peak, amplitude_spectrum, find_peaks
from analysis.stability.classify import NATURE_COLORS, NATURE_NAMES, default_figure_section

MICRO = 1e6
AXIS_NAMES = {"x": ("x", "vx", "X direction"), "y": ("y", "vy", "Y direction")}
_SCALES = {"m": (1e6, "µm"), "m/s": (1e3, "mm/s"), "rad": (1e6, "µrad"),
           "rad/s": (1e3, "mrad/s")}


def unit_scale(unit: str) -> tuple[float, str]:
    """(factor, unit) to draw a quantity in ``unit`` (SI) in: µm for m, mm/s for m/s, µrad
    for rad, mrad/s for rad/s, else the unit itself (factor 1)."""
    return _SCALES.get(unit, (1.0, unit))


def scaled_axis(axis, unit: str, magnitude: float | None = None) -> str:
    """Show ``axis`` (of data in SI ``unit``) in the unit of ``unit_scale`` (µm for m, …),
    by its tick labels: the data stay SI. With ``magnitude`` (the largest |value|, SI)
    the SI unit is kept for values of a thousandth or more (a Duffing oscillator's metres).
    Returns the unit shown."""
    from matplotlib.ticker import FuncFormatter

    factor, shown = unit_scale(unit)
    if factor == 1.0 or (magnitude is not None and magnitude >= 1e-3):
        return unit
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v * factor:.6g}"))
    return shown


def scale_of(ds: xr.Dataset, var: str) -> tuple[float, str]:
    """(factor, unit) to draw ``ds[var]`` in: µm for m, mm/s for m/s, µrad for rad, else the
    variable's own unit (from its attrs)."""
    unit = str(ds[var].attrs.get("units", "m" if var in ("x", "y") else
                                 "m/s" if var in ("vx", "vy") else ""))
    return unit_scale(unit)


def _axis_label(ds: xr.Dataset, var: str) -> str:
    unit = scale_of(ds, var)[1]
    return var + (f" ({unit})" if unit else "")


def run_title(ds: xr.Dataset) -> str:
    """A figure's title for a run: model, balls, speed and its forcing frequencies (a run
    whose speed follows a profile: the profile, 'ramp 1000 → 10000 rpm')."""
    parts = [str(ds.attrs.get("model") or _record_name(ds.attrs))]
    structure = balls_text(ds.attrs, "$N_b$", "")
    if structure:
        parts.append(structure)
    from analysis.integrate.speed_profile import profile_of

    profile = profile_of(ds.attrs)
    if profile is not None:  # a run-up: its frequencies change along the run
        return ", ".join([*parts, f"speed {profile.describe()}"])
    if "speed_rpm" in ds.attrs:
        parts.append(f"{float(ds.attrs['speed_rpm']):g} rpm")
    freqs = []
    if float(ds.attrs.get("shaft_hz", 0.0)) > 0:
        freqs.append(f"X = {float(ds.attrs['shaft_hz']):.2f} Hz")
    for bearing, vc in vc_frequencies(ds.attrs).items():
        freqs.append(f"VC{f'[{bearing}]' if bearing else ''} = {vc:.2f} Hz")
    forcing = run_period_parameter(ds.attrs)  # the forcing_period role
    if not freqs and forcing is not None and float(ds.attrs[forcing]) > 0:
        freqs.append(f"F = 1/{forcing} = {1 / float(ds.attrs[forcing]):.4g} Hz")
    return ", ".join(parts) + (f" ({', '.join(freqs)})" if freqs else "")


def _record_name(attrs) -> str:
    """A measured record's title: its file's name, channel(s) and bearing ('?' else)."""
    if attrs.get("kind") != "record":
        return "?"
    name = str(attrs.get("source_file", "record")).replace("\\", "/").rsplit("/", 1)[-1]
    bearing = f", bearing {attrs['bearing']}" if "bearing" in attrs else ""
    return f"{name} ({', '.join(str(attrs.get('state_names', '')).split())}{bearing})"


AMBIGUOUS_MARK = "*"
"""Appended to a label that another combination matches within the tolerance."""
LABEL_STEP_PT = 7.0
"""Vertical step (points) by which a peak label is moved up until it overlaps no other."""
MAX_LABEL_STEPS = 4
"""Steps a label may climb: beyond them labels would stack into a tower and the axes' top
would be raised to hold it (stretching the data into the bottom of the axes), so the label
of a smaller peak with no room within them is left out (the printed table still names it)."""


def plot_spectrum(ax, ds: xr.Dataset, var: str, peaks: list[Peak] | None = None,
                  f_max: float | None = None) -> None:
    """Amplitude spectrum of ``var`` (µm for metres, else scaled by ``scale_of``) on a log
    scale, peaks marked: named peaks (red ▼, label m·X + n·VC; ``*`` when another
    combination matches within the tolerance), unnamed peaks (grey ▽, their frequency in
    grey italics); a legend says which is which. Labels are kept apart by
    ``separate_peak_labels`` (called by the figure functions once the layout is fixed).
    The range reaches ``f_max`` (Hz; default ``f_max_of``) and at least every peak of
    ``var`` in ``peaks`` (default ``find_peaks``), so a printed peak is always drawn."""
    spec = amplitude_spectrum(ds, var)
    peaks = find_peaks(ds, var) if peaks is None else peaks
    nyquist = float(spec.frequency[-1])
    f_max = f_max or f_max_of(ds.attrs) or nyquist
    top = max((p.frequency_hz for p in peaks if p.direction == var), default=0.0)
    f_max = min(max(f_max, 1.06 * top), nyquist)  # every peak of the table is drawn
    factor, unit = scale_of(ds, var)
    sel = spec.sel(frequency=slice(0, f_max))
    ax.semilogy(sel.frequency, sel * factor, lw=0.8, color="C0")
    shown = [p for p in peaks if p.frequency_hz <= f_max and p.direction == var]
    kinds = set()
    for peak in shown:  # by descending amplitude: the larger peaks keep their place
        point = (peak.frequency_hz, peak.amplitude * factor)
        if peak.label:
            ax.plot(*point, "v", color="C3", ms=4)
            text = display_label(peak.label) + (AMBIGUOUS_MARK if peak.ambiguous else "")
            style = dict(color="black", fontstyle="normal")
            kinds.add("ambiguous" if peak.ambiguous else "named")
        else:
            ax.plot(*point, "v", color="0.45", ms=4, mfc="none")
            text = peak.name
            style = dict(color="0.35", fontstyle="italic")
            kinds.add("unnamed")
        note = ax.annotate(text, point, xytext=(0, 4), textcoords="offset points",
                           ha="center", va="bottom", fontsize=7, **style,
                           arrowprops=dict(arrowstyle="-", color="0.6", lw=0.5,
                                           shrinkA=0, shrinkB=2))
        note.peak_label = True  # found again by separate_peak_labels
    handles = []
    # peaks named by the defect vocabulary (spectrum --faults) carry no VC order
    faults = any(p.label and p.vc_order is None and p.shaft_order is None for p in shown)
    names = "a defect frequency, harmonic or sideband" if faults else "m·X + n·VC"
    none = "no defect frequency, harmonic or sideband" if faults else "no m·X + n·VC"
    if kinds & {"named", "ambiguous"}:
        handles.append(ax.plot([], [], "v", color="C3", ms=4, ls="none",
                               label=f"named peak: {names}")[0])
    if "ambiguous" in kinds:
        handles.append(ax.plot([], [], ls="none", marker="$*$", color="black", ms=5,
                               label=f"{AMBIGUOUS_MARK}: ambiguous, another name "
                                     "within 1.5 bins")[0])
    if "unnamed" in kinds:
        handles.append(ax.plot([], [], "v", color="0.45", mfc="none", ms=4, ls="none",
                               label=f"unnamed peak ({none} within 1.5 bins): "
                                     "its frequency")[0])
    if handles:
        ax.legend(handles=handles, fontsize=6.5, loc="lower right", framealpha=0.85)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"amplitude of {var}" + (f" ({unit})" if unit else ""))
    ax.set_xlim(0, f_max)
    ax.grid(True, which="both", alpha=0.3)


def peak_labels(ax) -> list:
    """The peak-label annotations ``plot_spectrum`` drew on ``ax``, in drawing order."""
    return [t for t in ax.texts if getattr(t, "peak_label", False)]


def label_box(note, renderer):
    """Display-space box of a label's text (without its leader line)."""
    from matplotlib.text import Text

    note.update_positions(renderer)
    return Text.get_window_extent(note, renderer)


def separate_peak_labels(fig: Figure, pad_px: float = 1.5, tries: int = 40) -> None:
    """Move peak labels up (in steps of ``LABEL_STEP_PT``, a leader line to the peak) until
    no two labels of an axes overlap each other or the legend, the larger peaks' labels
    placed first, at most ``MAX_LABEL_STEPS`` steps (a smaller peak's label with no room
    is left out); a label at an edge is aligned to stay inside the axes, whose top is
    raised until every label fits below it. Draws the
    figure once to fix the layout, then freezes it (so that the saved figure keeps the
    positions the labels were checked at)."""
    fig.canvas.draw()
    fig.set_layout_engine("none")
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        if not peak_labels(ax):
            continue
        for _ in range(6):
            notes = peak_labels(ax)  # without the labels left out on an earlier pass
            legend = ax.get_legend()
            placed = [legend.get_window_extent(renderer).padded(pad_px)] if legend else []
            for note in notes:
                note.xyann = (0.0, 4.0)
                note.set_horizontalalignment("center")
                box = label_box(note, renderer)
                if box.x0 < ax.bbox.x0:  # a peak near an edge: its label inside the axes
                    note.set_horizontalalignment("left")
                elif box.x1 > ax.bbox.x1:
                    note.set_horizontalalignment("right")
                for _ in range(min(tries, MAX_LABEL_STEPS) + 1):
                    box = label_box(note, renderer).padded(pad_px)
                    if not any(box.overlaps(other) for other in placed):
                        placed.append(box)
                        break
                    note.xyann = (0.0, note.xyann[1] + LABEL_STEP_PT)
                else:  # a smaller peak's label with no room within the stack: left out
                    note.remove()
            if not placed:
                break
            overflow = max(b.y1 for b in placed) - ax.bbox.y1
            if overflow <= 0:
                break
            low, high = ax.get_ylim()
            span = math.log10(high / low)  # decades over the axes' height
            grow = span * (overflow + 4 * pad_px) / max(ax.bbox.height - overflow, 1.0)
            ax.set_ylim(low, high * 10 ** grow)


def plot_poincare(ax, ds: xr.Dataset, var: str, section: str = "shaft",
                  against: str | None = None) -> None:
    """Stroboscopic Poincaré map: ``var`` (horizontal) against ``against`` (default: its
    velocity), any two state variables, in the units of ``scale_of``."""
    pts = poincare_section(ds, section)
    against = against or default_partner(ds, var)
    for name in (var, against):
        if name not in pts:
            raise InputError(f"{name}: not a state variable of this run; variables: "
                             f"{', '.join(state_names(ds))}")
    fx, _ = scale_of(ds, var)
    fy, _ = scale_of(ds, against)
    ax.plot(pts[var] * fx, pts[against] * fy, ".", ms=2.5, color="C2")
    period = section_period(ds, section)
    ax.set_xlabel(_axis_label(ds, var))
    ax.set_ylabel(_axis_label(ds, against))
    ax.set_title(f"Poincaré map, {section} section (every {period * 1e3:.4g} ms), "
                 f"{pts.sizes['k']} points", fontsize=8)
    ax.grid(True, alpha=0.3)


def paper_figure(ds: xr.Dataset, section: str = "shaft", f_max: float | None = None
                 ) -> Figure:
    """The paper's Figs. 2-6: spectrum and Poincaré map per displacement of the first body,
    X direction (a) and Y (b); ``f_max`` (Hz): the spectra's upper frequency (default: the
    run's own, ``f_max_of``; a series passes ``series_f_max``)."""
    variables = displacement_names(ds)
    fig, axes = plt.subplots(len(variables), 2, figsize=(11, 3.75 * len(variables) + 0.3),
                             layout="constrained", squeeze=False)
    for row, var in enumerate(variables):
        plot_spectrum(axes[row, 0], ds, var, f_max=f_max)
        name = AXIS_NAMES[var][2] if var in AXIS_NAMES else var
        axes[row, 0].set_title(f"({'abcdefgh'[row % 8]}) {name}: FFT", fontsize=9)
        plot_poincare(axes[row, 1], ds, var, section)
    fig.suptitle(run_title(ds), fontsize=10)
    plt.finish(fig, ds)
    separate_peak_labels(fig)
    return fig


def spectrum_figure(ds: xr.Dataset, variables: list[str] | tuple[str, ...] | None = None,
                    f_max: float | None = None, peaks: list[Peak] | None = None) -> Figure:
    """Spectra of ``variables`` (default: the first body's displacements) up to ``f_max``
    (Hz; default: the run's own, widened to every peak drawn); ``peaks``: the peaks to
    mark (default: ``find_peaks`` of each variable; the ``spectrum`` command passes the
    table it prints, named in its vocabulary)."""
    variables = tuple(variables or displacement_names(ds))
    fig, axes = plt.subplots(len(variables), 1, figsize=(8, 3.25 * len(variables)),
                             layout="constrained", squeeze=False)
    for ax, var in zip(axes[:, 0], variables, strict=True):
        mine = None if peaks is None else [p for p in peaks if p.direction == var]
        plot_spectrum(ax, ds, var, mine, f_max=f_max)
        ax.set_title(AXIS_NAMES[var][2] if var in AXIS_NAMES else var, fontsize=9)
    fig.suptitle(run_title(ds), fontsize=10)
    plt.finish(fig, ds)
    separate_peak_labels(fig)
    return fig


def poincare_figure(ds: xr.Dataset, section: str = "shaft",
                    pairs: list[tuple[str, str | None]] | None = None) -> Figure:
    """Poincaré maps of ``pairs`` (horizontal, vertical) of state variables (default: each
    displacement of the first body against its velocity)."""
    pairs = pairs or [(v, None) for v in displacement_names(ds)]
    fig, axes = plt.subplots(1, len(pairs), figsize=(5 * len(pairs), 4.5),
                             layout="constrained", squeeze=False)
    for ax, (var, against) in zip(axes[0], pairs, strict=True):
        plot_poincare(ax, ds, var, section, against)
    fig.suptitle(run_title(ds), fontsize=10)
    return plt.finish(fig, ds)


def save_figure(fig: Figure, path) -> None:
    """Render ``fig`` to a file (format by suffix: PNG, PDF, SVG, …) and release it: the one
    place every figure file is written (atomically). The file carries the provenance the
    figure was stamped with (``canvas.stamp``: model, spec path, SHA-256, version) in its
    metadata (``canvas.file_metadata``: PNG text chunks, a PDF's Subject, an SVG's
    Description)."""
    from analysis.io import atomic_write

    fmt = str(path).rsplit(".", 1)[-1].lower()
    metadata = plt.file_metadata(fig, fmt)
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=130, format=fmt, metadata=metadata))
    plt.close(fig)


def nature_colormap():
    """(colormap, norm) that colour the chart codes 0 … 5 as ``NATURE_COLORS`` (the class
    vocabulary of ``analysis.stability.classify``)."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    codes = sorted(NATURE_COLORS)
    cmap = ListedColormap([NATURE_COLORS[k] for k in codes])
    return cmap, BoundaryNorm(np.arange(codes[0] - 0.5, codes[-1] + 1.5), cmap.N)


def grid_label(ds: xr.Dataset, name: str) -> str:
    """A sweep axis for a figure: ``speed_rpm (rpm)``, ``n_balls[left] (balls in bearing
    left)``."""
    if name == "speed_rpm":
        return "speed_rpm (rpm)"
    long_name = ds[name].attrs.get("long_name", "")
    if name.startswith("n_balls[") and long_name:
        return f"{name} ({long_name})"
    unit = ds[name].attrs.get("units", ds.attrs.get(f"{name}_unit", "")) or \
        _model_unit(ds.attrs, name)
    return name + (f" ({unit})" if unit else "")


def grid_axis(axis, ds: xr.Dataset, name: str) -> None:
    """Label ``axis`` with the sweep axis ``name`` (``grid_label``) in the unit of
    ``scaled_axis`` (µm for a clearance in m, …)."""
    label = grid_label(ds, name)
    unit = label[len(name) + 2:-1] if label.endswith(")") and "(" in label else ""
    if unit and not name.startswith("n_balls"):
        label = f"{name} ({scaled_axis(axis, unit)})"
    axis.set_label_text(label)


def _model_unit(attrs, name: str) -> str:
    """The unit of parameter ``name`` in the model a result names ('' when unknown)."""
    from analysis.errors import BearingdynError
    from analysis.model import load_model

    for where in (attrs.get("model"), attrs.get("spec_file")):
        if not where:
            continue
        try:
            return load_model(str(where)).units.get(name, "")
        except (BearingdynError, OSError):
            continue
    return ""


def diagram_figure(ds: xr.Dataset, variables: list[str] | tuple[str, ...] | None = None
                   ) -> Figure:
    """Orbit diagram: grid parameter against the Poincaré samples of ``variables`` (any
    state variables; default: the first body's displacements, x and y, in µm); the up- and
    down-sweeps in different colours (hysteresis)."""
    param = ds.attrs["param"]
    variables = tuple(variables or displacement_names(ds))
    missing = [v for v in variables if v not in ds.data_vars or "k" not in ds[v].dims]
    if missing:
        raise InputError(f"{missing[0]}: not a state variable of this diagram; variables: "
                         f"{', '.join(state_names(ds))}")
    fig, axes = plt.subplots(len(variables), 1, figsize=(9, 1 + 3 * len(variables)),
                             sharex=True, layout="constrained", squeeze=False)
    axes = axes[:, 0]
    ms, alpha = dot_size(ds.sizes[param])
    for ax, var in zip(axes, variables, strict=True):
        factor, unit = scale_of(ds, var)
        for d, direction in enumerate(ds.direction.values):
            values = ds[var].isel(direction=d)
            grid = np.repeat(ds[param].values, values.sizes["k"])
            ax.plot(grid, values.values.ravel() * factor, ".", ms=ms, color=f"C{d}",
                    alpha=alpha)
            ax.plot([], [], "o", ms=3, color=f"C{d}", label=f"sweep {direction}")
        ax.set_ylabel(f"{var} on the {ds.attrs['section']} section"
                      + (f" ({unit})" if unit else ""))
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    grid_axis(axes[-1].xaxis, ds, param)
    structure = balls_text(ds.attrs, "$N_b$", "")
    fig.suptitle(f"{ds.attrs['model']}" + (f", {structure}" if structure else "")
                 + f": bifurcation diagram ({ds.sizes['k']} section points per value)",
                 fontsize=10)
    return plt.finish(fig, ds)


DENSE_VALUES = 2000
"""Grid values up to which a diagram's dots keep their size (2 pt, alpha 0.6)."""


def dot_size(values: int) -> tuple[float, float]:
    """(marker size in pt, alpha) of a diagram's dots over ``values`` grid values: 2 pt and
    0.6 up to ``DENSE_VALUES``; beyond, both shrink as the square root of the density (down
    to 0.5 pt and 0.15), so 20 000 speeds draw their structure rather than solid bands."""
    if values <= DENSE_VALUES:
        return 2.0, 0.6
    shrink = math.sqrt(DENSE_VALUES / values)
    return max(0.5, 2.0 * shrink), max(0.15, 0.6 * shrink)


def cell_edges(values: np.ndarray, whole: bool = False) -> np.ndarray:
    """Edges of the cells centred on grid ``values`` (sorted): halfway between neighbours,
    the outer ones as far out as the inner ones (matplotlib's ``shading="nearest"``). A
    single value gets a cell of its own: ±0.5 for a whole-number axis (``whole``, balls),
    else ±5 % of the value (±0.5 at 0), where "nearest" would draw a cell of no height."""
    values = np.asarray(values, dtype=float)
    if values.size == 1:
        v = float(values[0])
        half = 0.5 if whole or v == 0 else 0.05 * abs(v)
        return np.array([v - half, v + half])
    mid = (values[1:] + values[:-1]) / 2
    return np.concatenate([[2 * values[0] - mid[0]], mid, [2 * values[-1] - mid[-1]]])


def chart_figure(ds: xr.Dataset) -> Figure:
    """Stability chart: the class of the motion on the grid (colours with a legend), and
    the largest Lyapunov exponent. Every grid point is a cell, also on an axis of one
    value (``cell_edges``)."""
    from matplotlib.patches import Patch

    xname, yname = ds.attrs["x"], ds.attrs["y"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    cmap, norm = nature_colormap()
    xs, ys = ds[xname].values, ds[yname].values
    edges = (cell_edges(xs, xname.startswith("n_balls")),
             cell_edges(ys, yname.startswith("n_balls")))
    axes[0].pcolormesh(*edges, ds.nature_code.transpose(yname, xname), cmap=cmap, norm=norm,
                       shading="flat")
    present = sorted(set(np.unique(ds.nature_code.values).tolist()))
    handles = [Patch(color=NATURE_COLORS[k], label=NATURE_NAMES[k]) for k in present]
    if "multistable" in ds:
        handles.append(_mark_multistable(axes[0], ds, xname, yname, edges))
    axes[0].legend(handles=handles, fontsize=8, loc="upper center",  # outside the cells
                   bbox_to_anchor=(0.5, -0.14), ncol=min(3, len(handles)), frameon=False)
    axes[0].set_title("nature of the response", fontsize=9)
    lam = ds.lyapunov.transpose(yname, xname).values
    top = float(np.nanmax(np.abs(lam))) if np.isfinite(lam).any() else 1.0
    mesh = axes[1].pcolormesh(*edges, lam, cmap="RdBu_r", shading="flat", vmin=-top,
                              vmax=top)
    fig.colorbar(mesh, ax=axes[1], label="largest Lyapunov exponent (1/s)")
    axes[1].set_title("largest Lyapunov exponent", fontsize=9)
    from matplotlib.ticker import MaxNLocator

    for ax in axes:
        for axis, name, values in ((ax.xaxis, xname, xs), (ax.yaxis, yname, ys)):
            grid_axis(axis, ds, name)
            if values.size == 1:
                axis.set_ticks([float(values[0])])
            elif name.startswith("n_balls"):
                axis.set_major_locator(MaxNLocator(integer=True))
    fig.suptitle(f"{ds.attrs['model']}: stability chart", fontsize=10)
    return plt.finish(fig, ds)


def _mark_multistable(ax, ds: xr.Dataset, xname: str, yname: str, edges) -> Any:
    """Hatch the cells of a chart with ``--ics`` where two or more attractors coexist; the
    legend's handle."""
    from matplotlib.patches import Patch, Rectangle

    many = ds.multistable.transpose(yname, xname).values
    for iy, ix in zip(*np.nonzero(many), strict=True):
        ax.add_patch(Rectangle((edges[0][ix], edges[1][iy]), edges[0][ix + 1] - edges[0][ix],
                               edges[1][iy + 1] - edges[1][iy], fill=False, hatch="///",
                               edgecolor="k", lw=0.0))
    return Patch(facecolor="white", edgecolor="k", hatch="///",
                 label=f"multistable (≥ 2 attractors among {int(ds.attrs['ics'])} "
                       "initial states)")


def sensitivity_figure(ds: xr.Dataset, unit: str = "") -> Figure:
    """A chart over a short list of parameter values (the reproduction's sensitivity): one
    equal cell per value tried, ticks at the values themselves with ``unit`` (so the axis
    shows only values that were run, none beyond them), N_b as whole numbers."""
    from matplotlib.patches import Patch

    xname, yname = ds.attrs["x"], ds.attrs["y"]
    xs, ys = ds[xname].values, ds[yname].values
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
    cmap, norm = nature_colormap()
    codes = ds.nature_code.transpose(yname, xname).values
    axes[0].imshow(codes, cmap=cmap, norm=norm, origin="lower", aspect="auto")
    present = sorted(set(np.unique(codes).tolist()))
    axes[0].legend(handles=[Patch(color=NATURE_COLORS[k], label=NATURE_NAMES[k])
                            for k in present], fontsize=8, loc="upper right")
    axes[0].set_title("nature of the response", fontsize=9)
    lam = ds.lyapunov.transpose(yname, xname).values
    top = float(np.nanmax(np.abs(lam))) if np.isfinite(lam).any() else 1.0
    image = axes[1].imshow(lam, cmap="RdBu_r", vmin=-top, vmax=top, origin="lower",
                           aspect="auto")
    fig.colorbar(image, ax=axes[1], label="largest Lyapunov exponent (1/s)")
    axes[1].set_title("largest Lyapunov exponent", fontsize=9)
    factor, shown = unit_scale(unit)
    for ax in axes:
        ax.set_xticks(range(len(xs)), [f"{v * factor:.4g}" for v in xs])
        ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys])
        ax.set_xlabel(f"{xname} ({shown})" if unit else xname)
        ax.set_ylabel(grid_label(ds, yname) if not yname.startswith("n_balls")
                      else "$N_b$ (balls)")
    fig.suptitle(f"{ds.attrs['model']}: sensitivity to {xname}"
                 + (f" ({shown}), values tried" if unit else ", values tried"), fontsize=10)
    return plt.finish(fig, ds)


def any_figure(ds: xr.Dataset, variables: list[str] | None = None,
               path: str | Path | None = None) -> Figure:
    """The natural figure of any bearingdyn result file (``variables``: the state variables
    of a diagram or of a run's spectra and maps; default: the first body's
    displacements). ``InputError`` for a file of another program, a ``kind`` attribute
    that names no figure, or a run that cannot be analysed (``path``: the file, named in
    the message)."""
    path = path or ds.encoding.get("source", "the result")
    check_ours(ds, path)
    kind = ds.attrs.get("kind")
    if kind is not None and kind not in FIGURE_KINDS:
        raise InputError(f"result file: '{path}': attribute kind must be one of "
                         f"{', '.join(FIGURE_KINDS)} to be drawn, got {str(kind)[:60]!r} (a "
                         "damaged or edited file, or a result drawn by its own command)")
    if kind is not None:
        try:
            return FIGURE_KINDS[kind](ds, variables)
        except KeyError as exc:  # the kind says one thing, the content another
            raise InputError(f"result file: '{path}': attribute kind says {kind!r}, but the "
                             f"file lacks the {kind}'s {exc.args[0]!r} (a damaged or edited "
                             "file)") from None
    if "special" in ds and "param" in ds.attrs:
        return branch_figure([ds])
    ds = as_run(ds, path)
    if variables:
        fig = spectrum_figure(ds, variables)
        return fig
    return paper_figure(ds, default_figure_section(ds))


FIGURE_KINDS: dict[str, Callable[[xr.Dataset, list[str] | None], Figure]] = {
    "diagram": diagram_figure, "chart": lambda ds, variables: chart_figure(ds)}
"""The figure of each result kind (the ``kind`` attribute) that ``any_figure`` draws; a
result without one is a run or a branch."""

SPECIAL_MARKERS = {"LP": "s", "PD": "D", "NS": "*", "BP": "^", "grazing?": "x"}
CRITICALITY_STYLE = {
    "subcritical": ({"color": "red", "mfc": "none", "mew": 1.8}, " (subcritical)"),
    "nonsmooth": ({"color": "0.5", "mfc": "none", "mew": 1.2}, " (non-smooth)"),
}
"""How ``branch_figure`` marks a special point by its ``criticality`` (the branch file's
normal forms): a subcritical (dangerous) point red and hollow, a non-smooth one grey and
hollow; supercritical points and folds black."""


def _criticality_key(label: object) -> str:
    """The ``CRITICALITY_STYLE`` key of a branch's ``criticality`` label: subcritical
    whether or not the map is smooth there, else non-smooth, else none."""
    label = str(label)
    return "subcritical" if "subcritical" in label else \
        "nonsmooth" if label.startswith("nonsmooth") else ""


def branch_figure(branches: list[xr.Dataset]) -> Figure:
    """Continuation diagram: parameter vs orbit amplitude; stable solid, unstable dashed,
    special points (LP fold, PD period doubling, NS Neimark–Sacker, BP branch point),
    subcritical and non-smooth ones marked apart (``CRITICALITY_STYLE``)."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    for i, br in enumerate(branches):
        param = br.attrs["param"]
        lam, amp, stable = br[param].values, br.amplitude.values, br.stable.values
        color = f"C{i}"
        # one line per run of equal stability (short dashed pieces would look solid)
        cuts = np.nonzero(np.diff(stable))[0] + 1
        for run in np.split(np.arange(len(lam)), cuts):
            run = np.append(run, run[-1] + 1) if run[-1] + 1 < len(lam) else run
            ax.plot(lam[run], amp[run], color=color, ls="-" if stable[run[0]] else "--",
                    lw=1.4)
        ax.plot([], [], color=color, label=br.attrs.get("branch", f"branch {i + 1}"))
        crit = [_criticality_key(c) for c in br.criticality.values] if "criticality" in br \
            else [""] * len(lam)
        for j, kind in enumerate(br.special.values):
            if kind:
                style, note = CRITICALITY_STYLE.get(crit[j], ({"color": "k"}, ""))
                ax.plot(lam[j], amp[j], SPECIAL_MARKERS.get(str(kind), "o"), ms=6, **style)
                ax.annotate(str(kind) + note, (lam[j], amp[j]), xytext=(4, 4),
                            textcoords="offset points", fontsize=8, color=style["color"])
        for label, (style, note) in CRITICALITY_STYLE.items():
            if label in set(map(str, crit)):
                ax.plot([], [], "o", ms=6, **style, label=f"{label}{note}".strip())
    first = branches[0]
    grid_axis(ax.xaxis, first, first.attrs["param"])
    largest = max(float(np.nanmax(np.abs(br.amplitude.values), initial=0.0))
                  for br in branches)
    shown = scaled_axis(ax.yaxis, "m", largest)
    ax.set_ylabel(f"orbit amplitude, half peak-to-peak x ({shown})")
    ax.plot([], [], "k-", label="stable")
    ax.plot([], [], "k--", label="unstable")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(f"{first.attrs['model']}: periodic orbits ({first.attrs['period']}) "
                 "continued in " + first.attrs["param"], fontsize=9)
    return plt.finish(fig, first)


def distinct_colours(n: int) -> list:
    """``n`` colours that tell lines apart: matplotlib's ten for up to 10, else evenly
    spaced along a perceptual colormap (turbo)."""
    if n <= 10:
        return [f"C{i}" for i in range(n)]
    from matplotlib import colormaps

    cmap = colormaps["turbo"]
    return [cmap(0.04 + 0.92 * i / (n - 1)) for i in range(n)]


def converged_range(running: np.ndarray, ci95: np.ndarray, tail: float = 0.5
                    ) -> tuple[float, float]:
    """A vertical range (1/s) for running estimates (time × exponent): that of their last
    ``tail`` of the averaging and the exponents' 95 % intervals, widened by a quarter of
    itself (or 1/s when the estimates are flat), so the converged values fill the axes and
    the first wild swings of the average leave them."""
    running = np.asarray(running, dtype=float)
    part = running[int((1 - tail) * running.shape[0]):]
    finals = running[-1]
    low = float(np.nanmin([np.nanmin(part), np.nanmin(finals - ci95)]))
    high = float(np.nanmax([np.nanmax(part), np.nanmax(finals + ci95)]))
    pad = 0.25 * (high - low) or 1.0
    return low - pad, high + pad


def lyapunov_figure(result: xr.Dataset) -> Figure:
    """Running estimates of the Lyapunov exponents against time (convergence check): one
    distinct colour per exponent, the legend beside the axes, the vertical range set by the
    converged values (``converged_range``), the sum rule under the title. A result with
    its tangent transient (``t_transient``) shows it dashed, in a grey span, at the same
    scale."""
    index = result.index.values
    colours = distinct_colours(len(index))
    fig, ax = plt.subplots(figsize=(9.5 if len(index) > 4 else 8.5, 4.8),
                           layout="constrained")
    if result.sizes.get("t_transient", 0):
        t = result.t_transient.values
        ax.axvspan(t[0] - (t[1] - t[0] if len(t) > 1 else 0.0), t[-1], color="0.92",
                   label="tangent transient (discarded)")
        for k, colour in zip(index, colours, strict=True):
            ax.plot(t, result.transient_running.sel(index=k), ls="--", lw=0.7,
                    color=colour, alpha=0.6)
    for k, colour in zip(index, colours, strict=True):
        ax.plot(result.t, result.running.sel(index=k), color=colour, lw=1.1,
                label=f"λ{k} = {float(result.exponents.sel(index=k)):.4g} ± "
                      f"{float(result.ci95.sel(index=k)):.2g} 1/s")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_ylim(*converged_range(result.running.transpose("t", "index").values,
                                 result.ci95.values))
    ax.set_xlabel("t (s)")
    ax.set_ylabel("running estimate (1/s)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    ax.grid(True, alpha=0.3)
    ax.set_title(run_title(result) + f"\nΣλ = {result.attrs['sum_of_exponents']:.5g} 1/s, "
                 f"mean divergence {result.attrs['mean_divergence']:.5g} 1/s", fontsize=9)
    return plt.finish(fig, result)


def _pitch_text(ds: xr.Dataset, pitch: float) -> str:
    """'one ball pitch 2π/N_b = 45°' (one bearing) or 'the common pitch 2π/gcd(8, 10) =
    180°' (several)."""
    balls = [int(v) for k, v in ds.attrs.items() if str(k).startswith("n_balls")]
    degrees = f"{math.degrees(pitch):.4g}°"
    if len(balls) == 1:
        return f"one ball pitch 2π/N_b = 2π/{balls[0]} = {degrees}"
    if balls:
        return (f"the common pitch 2π/gcd({', '.join(map(str, balls))}) = {degrees}")
    return f"one pitch = {degrees}"


def coefficient_name(coordinates: list[str]):
    """``name(row, column)`` of a coefficient: ``k_xy`` when every coordinate is one letter
    (a one-body model), else ``k[x_rotor, y_housing]`` so that the names stay apart
    (``k_x_rotorx_rotor`` reads as one word)."""
    if all(len(c) == 1 for c in coordinates):
        return lambda row, column: f"k_{row}{column}"
    return lambda row, column: f"k[{row}, {column}]"


def stiffness_figure(ds: xr.Dataset) -> Figure:
    """Linearised coefficients over one cage pitch (``analysis.stability.statics``): the
    direct stiffnesses and the static equilibrium against the cage angle ψ (degrees, over
    the pitch 2π/N_b, its first value repeated at its end), one axes per unit (MN/m for
    translations, kN·m/rad for tilts; µm and µrad), the pitch means dashed, the legends
    beside the lines they name."""
    coords = [str(c) for c in ds.row.values]
    units = dict(zip(coords, ds.position.attrs.get("units", "").split(", "), strict=False))
    pitch = float(ds.attrs.get("cage_pitch", 0.0)) or float(
        ds.cage_angle.values[-1] + (ds.cage_angle.values[1] - ds.cage_angle.values[0]))
    angle = np.degrees(np.append(ds.cage_angle.values, pitch))  # ψ = pitch is ψ = 0 again

    def closed(values):
        return np.append(values, values[:1])

    name = coefficient_name(coords)
    kinds = [kind for kind in ("m", "rad") if any(units.get(c, "m") == kind for c in coords)]
    fig, axes = plt.subplots(len(kinds), 2, figsize=(11, 3.4 * len(kinds) + 0.6),
                             layout="constrained", squeeze=False, sharex=True)
    stiff_unit = {"m": (1e-6, "MN/m"), "rad": (1e-3, "kN·m/rad")}
    for row, kind in enumerate(kinds):
        chosen = [(i, c) for i, c in enumerate(coords) if units.get(c, "m") == kind]
        factor, unit = stiff_unit[kind]
        for n, (i, c) in enumerate(chosen):
            colour = f"C{n}"
            axes[row, 0].plot(angle, closed(ds.stiffness.values[:, i, i]) * factor, ".-",
                              lw=1, ms=3, color=colour, label=name(c, c))
            axes[row, 0].axhline(float(ds.stiffness_mean.values[i, i]) * factor, ls="--",
                                 lw=0.8, color=colour, label=f"{name(c, c)} mean over the pitch")
            pos_factor = unit_scale(kind)[0]
            axes[row, 1].plot(angle, closed(ds.position.values[:, i]) * pos_factor, ".-",
                              lw=1, ms=3, color=colour, label=c)
        axes[row, 0].set_ylabel(f"direct stiffness ({unit})")
        axes[row, 1].set_ylabel(f"static equilibrium ({unit_scale(kind)[1]})")
        for ax in axes[row]:
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                      borderaxespad=0)
    from matplotlib.ticker import FixedLocator, FuncFormatter

    ticks = np.degrees(pitch) * np.linspace(0, 1, 5)
    for ax in axes[-1]:
        ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.4g}"))
        ax.set_xlim(-0.02 * ticks[-1], 1.02 * ticks[-1])
        ax.set_xlabel(f"cage angle ψ (degrees), over {_pitch_text(ds, pitch)}")
    fig.suptitle(run_title(ds) + ": static equilibrium and stiffness", fontsize=10)
    return plt.finish(fig, ds)


__all__ = [
    "branch_figure",
    "display_label",
    "lyapunov_figure",
    "paper_figure",
    "plot_poincare",
    "plot_spectrum",
    "poincare_figure",
    "save_figure",
    "scale_of",
    "sensitivity_figure",
    "separate_peak_labels",
    "series_f_max",
    "spectrum_figure",
    "stiffness_figure",
]
