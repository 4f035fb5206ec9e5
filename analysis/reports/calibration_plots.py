"""The corner figure of a calibration: each calibrated parameter's posterior marginal on
the diagonal, every pair's accepted sets below it (marker area by weight), the prior's
range as the axes' limits, units on the labels, log axes for log priors."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from analysis.reports.canvas import finish, subplots


def _prior_of(ds: xr.Dataset, name: str) -> tuple[float, float, bool]:
    """(lo, hi, log) of a calibrated parameter from its ``prior`` attr (NAME:LO:HI[:log])."""
    parts = str(ds[name].attrs["prior"]).split(":")
    return float(parts[1]), float(parts[2]), len(parts) == 4 and parts[3] == "log"


def _plain_log(axis, lo: float, hi: float) -> None:
    """Log-axis ticks at 1, 2, 5 × 10^k (1, 3 × 10^k over more than two decades, 10^k over
    more than three) written as plain numbers (``%g``), no minor labels."""
    decades = np.log10(hi / lo)
    subs = (1.0, 2.0, 5.0) if decades <= 2 else (1.0, 3.0) if decades <= 3 else (1.0,)
    axis.set_major_locator(LogLocator(subs=subs))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def corner_figure(ds: xr.Dataset, truth: dict[str, float] | None = None) -> Figure:
    """Corner figure of a calibration Dataset (``analysis.inference.results.to_dataset``):
    marginals (weighted histograms of the posterior, the prior's Sobol round in grey) and
    pairs (grey: the prior's Sobol round; red: the posterior's sets, area by weight; black:
    every set, of any round, that matches the most rows).
    ``truth``: parameter values to mark (a synthetic test's)."""
    names = [str(n).strip() for n in str(ds.attrs["priors"]).split(" ")]
    names = [n.split(":")[0] for n in names]
    p = len(names)
    fig, axes = subplots(p, p, figsize=(2.6 * p + 0.6, 2.4 * p + 0.6), squeeze=False,
                         layout="constrained")
    w = ds.weight.values
    post = w > 0
    first = ds["member_round"].values == 0
    top = int(ds.matched.max())
    best = ds.matched.values == top
    for i, yname in enumerate(names):
        ylo, yhi, ylog = _prior_of(ds, yname)
        for j, xname in enumerate(names):
            ax = axes[i, j]
            xlo, xhi, xlog = _prior_of(ds, xname)
            if j > i:
                ax.set_axis_off()
                continue
            x = ds[xname].values
            unit = ds[xname].attrs.get("units", "")
            if i == j:
                bins = int(np.clip(2 * np.sqrt(post.sum()), 6, 20)) + 1
                edges = (np.geomspace(xlo, xhi, bins) if xlog else np.linspace(xlo, xhi, bins))
                # shares per bin (bins equal in log for a log prior): heights compare
                ax.hist(x[first], bins=edges, weights=np.full(first.sum(), 1 / first.sum()),
                        color="0.8", label="prior (Sobol round)")
                ax.hist(x[post], bins=edges, weights=w[post] / w[post].sum(),
                        histtype="step", color="#e76f51", lw=1.5, label="posterior")
                ax.set_yticks([])
                if i == 0:
                    ax.legend(fontsize=7, loc="upper right")
            else:
                y = ds[yname].values
                ax.scatter(x[first], y[first], s=4, color="0.75", lw=0)
                area = min(200.0, 2000.0 / max(post.sum(), 1))
                ax.scatter(x[post], y[post], s=2 + area * w[post] / max(w.max(), 1e-300),
                           color="#e76f51", alpha=0.5, lw=0)
                ax.scatter(x[best], y[best], s=5, color="k", lw=0,
                           label=f"sets matching {top} rows")
                if i == p - 1 and j == 0:
                    ax.legend(fontsize=7, loc="lower left")
                ax.set_ylim(ylo, yhi)
                if ylog:
                    ax.set_yscale("log")
                    _plain_log(ax.yaxis, ylo, yhi)
                if j == 0:
                    yunit = ds[yname].attrs.get("units", "")
                    ax.set_ylabel(f"{yname} ({yunit})" if yunit else yname)
                if truth and xname in truth and yname in truth:
                    ax.plot(truth[xname], truth[yname], "k+", ms=10, mew=1.5)
            if truth and i == j and xname in truth:
                ax.axvline(truth[xname], color="k", lw=1)
            ax.set_xlim(xlo, xhi)
            if xlog:
                ax.set_xscale("log")
                _plain_log(ax.xaxis, xlo, xhi)
            if i == p - 1:
                ax.set_xlabel(f"{xname} ({unit})" if unit else xname)
    fig.suptitle(f"{ds.attrs.get('model', '')} against {ds.attrs.get('target', '')}: "
                 f"posterior after {ds.sizes['round']} rounds, best "
                 f"{int(ds.attrs.get('best_matched', 0))} of {ds.sizes['row']} rows")
    return finish(fig, ds)
