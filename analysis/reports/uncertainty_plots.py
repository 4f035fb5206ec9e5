"""The figure of an uncertainty study (``analysis.uncertainty.study``): the probability of
each regime against the swept parameter as stacked bands, each regime's Wilson 95 %
interval drawn as error bars at the top edge of its band, and beside them the Sobol'
indices of the chaotic indicator (total, first order, with their intervals) per uncertain
parameter against the same axis."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from analysis.reports.canvas import finish, subplots
from analysis.stability.classify import NATURE_CODES, NATURE_COLORS

DIVERGED = "#cccccc"


def regime_colour(name: str) -> str:
    """The chart's colour of a regime (periodic-n, n >= 3, share one; diverged grey)."""
    if name == "diverged":
        return DIVERGED
    key = name if name in NATURE_CODES else "periodic-n"
    return NATURE_COLORS[NATURE_CODES[key]]


def uncertainty_figure(ds: xr.Dataset) -> Figure:
    """Stacked regime probabilities with intervals (left) and Sobol' indices of P(chaos)
    (right) against the swept parameter of an uncertainty result."""
    axis = str(ds.attrs["axis"])
    x = np.asarray(ds[axis].values, dtype=float)
    fig, (left, right) = subplots(1, 2, figsize=(10.5, 4.2),
                                  gridspec_kw={"width_ratios": [1.6, 1.0]})
    bottom = np.zeros(len(x))
    wide = len(x) > 1 and axis != "n_balls"  # bands over a parameter, bars over balls
    width = 0.7 * (float(np.min(np.diff(x))) if len(x) > 1 else 1.0)
    for k, name in enumerate(ds["regime"].values):
        p = ds["probability"].values[:, k]
        lo, hi = ds["probability_ci95"].values[:, k, 0], ds["probability_ci95"].values[:, k, 1]
        colour = regime_colour(str(name))
        if wide:
            left.fill_between(x, bottom, bottom + p, color=colour, alpha=0.85, lw=0,
                              label=str(name), step=None)
        else:
            left.bar(x, p, bottom=bottom, color=colour, width=width, label=str(name))
        top = bottom + p
        left.errorbar(x, top, yerr=np.maximum([p - lo, hi - p], 0.0), fmt="none", ecolor="k",
                      elinewidth=0.8, capsize=2.5)
        bottom = top
    pad = 0.03 * float(np.ptp(x)) if wide else width  # the end intervals stay in view
    left.set_xlim(x.min() - pad, x.max() + pad)
    if axis == "n_balls":
        left.set_xticks(x)
    left.set_ylim(0, 1)
    unit = ds.attrs.get("axis_units", "")
    label = "balls N_b" if axis == "n_balls" else f"{axis}" + (f" ({unit})" if unit else "")
    left.set_xlabel(label)
    left.set_ylabel("probability (bars: Wilson 95 %)")
    left.set_title(f"regime probabilities, {int(ds.attrs['independent_draws'])} draws "
                   "per value")
    fig.suptitle(f"{ds.attrs['model']}: {ds.attrs['dists']}", fontsize=8)
    left.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False)
    for j, name in enumerate(ds["parameter"].values):
        for kind, style in (("ST", "-o"), ("S1", "--s")):
            v = ds[f"sobol_chaotic_{kind}"].values[:, j]
            ci = ds[f"sobol_chaotic_{kind}_ci95"].values[:, j]
            line = right.plot(x, v, style, ms=4, label=f"{kind} {name}")[0]
            ok = np.isfinite(v)
            right.errorbar(x[ok], v[ok],
                           yerr=np.maximum([v[ok] - ci[ok, 0], ci[ok, 1] - v[ok]], 0.0),
                           fmt="none", ecolor=line.get_color(), elinewidth=0.8, capsize=2)
    right.set_ylim(-0.1, 1.2)
    right.set_xlabel(label)
    right.set_ylabel("Sobol' index of P(chaos)")
    right.set_title("which tolerance matters")
    if axis == "n_balls":
        right.set_xticks(x)
    right.set_xlim(left.get_xlim())
    right.legend(fontsize=7, frameon=False)
    fig.tight_layout()
    return finish(fig, ds)
