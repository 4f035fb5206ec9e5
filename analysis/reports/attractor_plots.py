"""Figures of attractor studies: basins on a grid, basin fractions, global continuation.

Every attractor is named in the legend by its id, class and period; axes carry units (µm,
mm/s … as the other figures, ``plots.scale_of``). Colours: one per attractor id (the same
id the same colour in every figure of a study), grey for diverged, white for undecided,
black for failed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.reports import canvas as plt
from analysis.reports.plots import SPECIAL_MARKERS, cell_edges, run_title, scale_of, scaled_axis
from analysis.stability.attractors.dataset import unsettled

SPECIAL_COLORS = {-1: "#9e9e9e", -2: "#ffffff", -3: "#000000"}
"""Colours of the labels that are not attractors: diverged (grey), undecided (white),
failed (black: a block whose integration failed)."""


def attractor_color(i: int) -> str:
    """The colour of attractor ``i`` (tab10 by id; the specials' own)."""
    if i in SPECIAL_COLORS:
        return SPECIAL_COLORS[i]
    from matplotlib import colormaps

    r, g, b, _ = colormaps["tab10"]((i - 1) % 10)
    return f"#{round(255 * r):02x}{round(255 * g):02x}{round(255 * b):02x}"


def attractor_name(ds: xr.Dataset, i: int) -> str:
    """``2: periodic-3 (period 3)``, ``1: quasi-periodic (λ1 = -3.2 ± 1.1 1/s)``,
    ``-1: diverged``."""
    row = ds.sel(attractor=i)
    nature = str(row.nature.values)
    if i < 0:
        return f"{i}: {nature}"
    period = int(row.period)
    if period > 0:
        return f"{i}: {nature} (period {period})"
    return f"{i}: {nature} (λ1 = {float(row.lambda1):.3g} ± {float(row.lambda1_ci95):.2g} 1/s)"


def _unit_scale(unit: str, magnitude: float) -> tuple[float, str]:
    """(factor, unit) to draw a quantity of ``unit`` whose values reach ``magnitude`` in:
    ``plots.scale_of``'s small unit (µm, mm/s, µrad) for values below a thousandth of the
    SI unit, else the SI unit itself (a Duffing oscillator's metres stay metres)."""
    factor, small = scale_of(xr.Dataset({"q": ((), 0.0, {"units": unit})}), "q")
    return (factor, small) if magnitude < 1e-3 else (1.0, unit)


def _axis(ds: xr.Dataset, var: str) -> tuple[float, str]:
    """(factor, label with unit) of a grid coordinate."""
    magnitude = float(np.nanmax(np.abs(ds[var].values)))
    factor, unit = _unit_scale(str(ds[var].attrs.get("units", "")), magnitude)
    return factor, var.removesuffix("_grid") + (f" ({unit})" if unit else "")


def basins_figure(ds: xr.Dataset) -> Figure:
    """The attractor id of every grid cell, each attractor's section points on top (where
    the grid's two coordinates show them), a legend naming each attractor with its basin
    fraction of the grid."""
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    xname, yname = ds.attrs["basin_x"], ds.attrs["basin_y"]
    xg, yg = f"{xname}_grid", f"{yname}_grid"
    fx, xlabel = _axis(ds, xg)
    fy, ylabel = _axis(ds, yg)
    ids = [int(i) for i in ds.attractor.values]
    order = sorted(ids)
    cmap = ListedColormap([attractor_color(i) for i in order])
    norm = BoundaryNorm(np.append(np.array(order) - 0.5, order[-1] + 0.5), cmap.N)
    fig, ax = plt.subplots(figsize=(7.5, 5.6), layout="constrained")
    ax.pcolormesh(cell_edges(ds[xg].values) * fx, cell_edges(ds[yg].values) * fy,
                  ds.basin.values, cmap=cmap, norm=norm, shading="flat")
    states = [str(s) for s in ds.state.values]
    handles = []
    for i in ids:
        fraction = float(ds.fraction.sel(attractor=i))
        handles.append(Patch(facecolor=attractor_color(i), edgecolor="k", lw=0.5,
                             label=f"{attractor_name(ds, i)}, {100 * fraction:.1f} %"))
        pts = ds.section_points.sel(attractor=i).values
        pts = pts[np.isfinite(pts).all(axis=1)]
        if i > 0 and len(pts):
            ax.plot(pts[:, states.index(xname)] * fx, pts[:, states.index(yname)] * fy, "X",
                    ms=8, mfc="k", mec="w", mew=0.8)
    ax.legend(handles=handles, fontsize=8, loc="upper right", framealpha=0.9,
              title="attractor: class, basin share", title_fontsize=8)
    advice = unsettled(ds)
    if advice:
        import textwrap

        ax.text(0.5, 0.5, "\n".join(textwrap.fill(line, 70) for line in advice),
                transform=ax.transAxes, ha="center", va="center", fontsize=8,
                bbox={"facecolor": "#fff3cd", "edgecolor": "#b08800"})
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(f"basins of attraction on the {ds.attrs['section']} section "
                 "(crosses: the attractors' section points)", fontsize=9)
    fig.suptitle(run_title(ds), fontsize=10)
    return fig


def fractions_figure(ds: xr.Dataset) -> Figure:
    """Each attractor's basin fraction with its standard error (bars)."""
    ids = [int(i) for i in ds.attractor.values]
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    pos = np.arange(len(ids))
    ax.bar(pos, ds.fraction.values, yerr=ds.fraction_stderr.values, capsize=4,
           color=[attractor_color(i) for i in ids], edgecolor="k", lw=0.6)
    ax.set_xticks(pos, [attractor_name(ds, i) for i in ids], rotation=15, ha="right",
                  fontsize=8)
    ax.set_ylabel("basin fraction (± standard error)")
    ax.set_ylim(0, 1)
    ax.set_title(f"{int(ds.attrs['samples'])} random initial states in "
                 f"{ds.attrs['box']}", fontsize=9)
    fig.suptitle(run_title(ds), fontsize=10)
    return fig


def continuation_figure(ds: xr.Dataset, branches: Sequence[xr.Dataset] = ()) -> Figure:
    """Top: the amplitude of the first state of each attractor against the parameter, with
    continuation branches (``branches``: files of ``bearingdyn continue``; stable solid,
    unstable dashed, special points marked) overlaid. Bottom: each attractor's basin
    fraction with its standard error (bars), drawn only at the values where it exists (a
    line joins consecutive values only)."""
    param = str(ds.attrs["param"])
    unit = str(ds.value.attrs.get("units", ""))
    first = str(ds.state.values[0])
    amplitude = ds.amplitude.sel(state=first).values
    factor, amp_unit = _unit_scale(str(ds.state_units.values[0]),
                                   float(np.nanmax(np.abs(amplitude), initial=0.0)))
    values = ds.value.values
    ids = [int(i) for i in ds.attractor.values]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7), sharex=True,
                                      layout="constrained", height_ratios=(3, 2))
    named: set[str] = set()
    for br in branches:
        _overlay_branch(top, br, factor, named)
    for i in ids:
        if i < 0:
            continue
        here = ds.present.sel(attractor=i).values
        amp = ds.amplitude.sel(attractor=i, state=first).values
        natures = sorted({str(n) for n in ds.nature.sel(attractor=i).values[here]})
        top.plot(values[here], amp[here] * factor, "o", ms=5, color=attractor_color(i),
                 mec="k", mew=0.4, label=f"attractor {i}: {', '.join(natures)}")
    top.set_ylabel(f"amplitude of {first} ({amp_unit})")
    top.legend(fontsize=8)
    for i in ids:
        _fraction_line(bottom, ds, i)
    bottom.set_ylim(-0.02, 1.02)
    bottom.set_ylabel("basin fraction (± standard error)")
    bottom.set_xlabel(f"{param} ({scaled_axis(bottom.xaxis, unit)})" if unit else param)
    bottom.legend(fontsize=8, loc="best", title="attractor", title_fontsize=8)
    fig.suptitle(f"{ds.attrs['model']}: attractors along {param} "
                 f"({int(ds.attrs['samples'])} random states per value, "
                 f"{ds.attrs['section']} section)", fontsize=10)
    return fig


def _fraction_line(ax, ds: xr.Dataset, i: int) -> None:
    """Attractor ``i``'s basin fraction ± its standard error at the values where it is
    present; consecutive values joined, absences left as gaps (never interpolated)."""
    values = ds.value.values
    here = ds.present.sel(attractor=i).values
    if not here.any():
        return
    f = ds.fraction.sel(attractor=i).values
    se = ds.fraction_stderr.sel(attractor=i).values
    name = f"{i}" if i > 0 else str(ds.nature.sel(attractor=i).values[here][0])
    color = attractor_color(i)
    shown = np.where(here, f, np.nan)  # NaN breaks the line where it is absent
    ax.plot(values, shown, "-", color=color if i != -2 else "#666666", lw=1.2)
    ax.errorbar(values[here], f[here], yerr=se[here], fmt="o", ms=4, capsize=3,
                color=color if i != -2 else "#666666", mec="k", mew=0.4, label=name)


def _overlay_branch(ax, br: xr.Dataset, factor: float, named: set[str]) -> None:
    """A continuation branch: amplitude of its first state against its parameter, stable
    solid, unstable dashed, special points marked; its name enters the legend once
    (``named``: the names already there)."""
    param = br.attrs["param"]
    lam, amp, stable = br[param].values, br.amplitude.values * factor, br.stable.values
    cuts = np.nonzero(np.diff(stable))[0] + 1
    for run in np.split(np.arange(len(lam)), cuts):
        run = np.append(run, run[-1] + 1) if run[-1] + 1 < len(lam) else run
        ax.plot(lam[run], amp[run], color="k", ls="-" if stable[run[0]] else "--", lw=1.0)
    name = f"{br.attrs.get('branch', 'branch')} (continue; dashed: unstable)"
    if name not in named:
        named.add(name)
        ax.plot([], [], color="k", lw=1.0, label=name)
    for j, kind in enumerate(br.special.values):
        if kind:
            ax.plot(lam[j], amp[j], SPECIAL_MARKERS.get(str(kind), "o"), color="k", ms=6)
            ax.annotate(str(kind), (lam[j], amp[j]), xytext=(4, 4),
                        textcoords="offset points", fontsize=8)


def study_figure(ds: xr.Dataset, branches: Sequence[xr.Dataset] = ()) -> Figure:
    """The figure of any attractor study file, by its ``kind``."""
    kind = ds.attrs.get("kind")
    if kind == "basins":
        return plt.finish(basins_figure(ds), ds)
    if kind == "attractor-continuation":
        return plt.finish(continuation_figure(ds, branches), ds)
    return plt.finish(fractions_figure(ds), ds)
