"""Figures of two-parameter curves (``analysis.stability.curves``), over a stability chart
(``analysis.sweeps.chart.stability_chart``) of the same two parameters when one is given."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.errors import InputError
from analysis.reports import canvas as plt  # pyplot's subplots, without pyplot
from analysis.reports.plots import cell_edges, nature_colormap, scaled_axis
from analysis.stability.classify import NATURE_COLORS, NATURE_NAMES

CURVE_STYLES = {"LP": ("C0", "-"), "PD": ("k", "-"), "NS": ("C3", "-")}
CODIM2_MARKERS = {"CP": "v", "R1": "s", "R2": "D", "R3": "^", "R4": "p", "LPPD": "X",
                  "LPNS": "P", "PDNS": "h", "GPD": "*", "CH": "*"}
CURVE_NAMES = {"LP": "fold (LP) curve", "PD": "period-doubling (PD) curve",
               "NS": "Neimark–Sacker (NS) curve"}


def axis_label(ds: xr.Dataset, name: str) -> str:
    """``radial_load (N)``: a parameter and its unit from the variable's attributes."""
    unit = str(ds[name].attrs.get("units", ""))
    return name + (f" ({unit})" if unit else "")


def curve_axes(curves: list[xr.Dataset], chart: xr.Dataset | None) -> tuple[str, str]:
    """(x, y) parameter names of the figure: the chart's axes, or the first curve's
    (branch parameter on x). Every curve must carry both as variables."""
    if not curves:
        raise InputError("curves: nothing to draw")
    first = curves[0]
    x, y = (chart.attrs["x"], chart.attrs["y"]) if chart is not None else (
        first.attrs["param1"], first.attrs["param2"])
    for ds in curves:
        missing = [name for name in (x, y) if name not in ds.data_vars]
        if missing:
            raise InputError(f"chart: its axes are {x} and {y}, but the curve of "
                             f"{ds.attrs.get('param1')} and {ds.attrs.get('param2')} has no "
                             f"{missing[0]}")
    return x, y


def draw_chart(ax, chart: xr.Dataset, x: str, y: str) -> None:
    """The chart's classes (periodic-1, periodic-2, …) as coloured cells with a legend."""
    from matplotlib.patches import Patch

    cmap, norm = nature_colormap()
    codes = chart.nature_code.transpose(y, x)
    ax.pcolormesh(cell_edges(chart[x].values, x.startswith("n_balls")),
                  cell_edges(chart[y].values, y.startswith("n_balls")), codes, cmap=cmap,
                  norm=norm, shading="flat", alpha=0.75)
    present = sorted(set(np.unique(codes.values).tolist()))
    ax.legend(handles=[Patch(color=NATURE_COLORS[k], alpha=0.75, label=NATURE_NAMES[k])
                       for k in present], fontsize=8, loc="upper left",
              bbox_to_anchor=(1.01, 1.0), title="brute-force chart", title_fontsize=8)


def draw_curve(ax, ds: xr.Dataset, x: str, y: str):
    """One curve and its labelled codimension-two points; returns the line."""
    color, style = CURVE_STYLES.get(str(ds.attrs.get("curve")), ("C1", "-"))
    (line,) = ax.plot(ds[x], ds[y], style, color=color, lw=1.6,
                      label=CURVE_NAMES.get(str(ds.attrs.get("curve")), "curve"))
    for i, label in enumerate(ds.special.values):
        if label:
            xi, yi = float(ds[x].values[i]), float(ds[y].values[i])
            ax.plot(xi, yi, CODIM2_MARKERS.get(str(label), "o"), color="k", ms=7,
                    mfc="w", mew=1.4)
            ax.annotate(str(label), (xi, yi), xytext=(5, 5), textcoords="offset points",
                        fontsize=8)
    return line


def curve_figure(curves: list[xr.Dataset], chart: xr.Dataset | None = None,
                 title: str | None = None) -> Figure:
    """Curves in the plane of their two parameters (with units), over the classes of
    ``chart`` (a stability chart of the same two parameters) when given."""
    x, y = curve_axes(curves, chart)
    fig, ax = plt.subplots(figsize=(9.5 if chart is not None else 8, 5.5),
                           layout="constrained")
    if chart is not None:
        draw_chart(ax, chart, x, y)
        ax.add_artist(ax.get_legend())
    lines = [draw_curve(ax, ds, x, y) for ds in curves]
    seen = {}
    for line in lines:
        seen.setdefault(line.get_label(), line)
    outside = chart is not None  # the chart's legend is outside, top right: this one below
    ax.legend(handles=list(seen.values()), fontsize=8,
              loc="lower left" if outside else "upper right",
              bbox_to_anchor=(1.01, 0.0) if outside else None)
    for axis, name in ((ax.xaxis, x), (ax.yaxis, y)):  # µm for a clearance in m, …
        unit = str(curves[0][name].attrs.get("units", ""))
        axis.set_label_text(name + (f" ({scaled_axis(axis, unit)})" if unit else ""))
    if chart is not None:
        ax.set_xlim(float(chart[x].min()), float(chart[x].max()))
        ax.set_ylim(float(chart[y].min()), float(chart[y].max()))
    ax.grid(True, alpha=0.3)
    first = curves[0]
    ax.set_title(title or f"{first.attrs['model']}: "
                 + ", ".join(sorted({CURVE_NAMES.get(str(c.attrs['curve']), 'curve')
                                     for c in curves}))
                 + (" over a brute-force stability chart" if chart is not None else ""),
                 fontsize=9)
    return plt.finish(fig, curves[0])
