"""Two-parameter curves over a brute-force stability chart of the same two parameters.

    python docs/scripts/curves_figure.py chart.nc pd-up.nc pd1-down.nc pd2-down.nc \\
        [-o docs/figures/curves-balanced-rotor.png]

Reads a chart of ``bearingdyn chart`` and curve files of ``bearingdyn curve`` (the commands
are in docs/stability.md, "Two-parameter curves": the balanced rotor, N_b = 8, VC section,
its period-doubling curve in speed (rpm) and radial load (N) in three pieces). Draws the
curves over the chart's classes (``analysis.reports.curve_plots.curve_figure``) and prints,
for the chart's cells, how the classes split between inside and outside the curve: a cell
is inside when, along its row (fixed load), an odd number of curve crossings lie at lower
speed (the crossings linear between curve points). About 2 s.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.io import open_result
from analysis.reports.curve_plots import curve_figure
from analysis.reports.plots import save_figure


def crossings(curves: list[xr.Dataset], x: str, y: str, value: float) -> np.ndarray:
    """Values of ``x`` where the curves cross ``y = value`` (sorted, duplicates merged)."""
    out = []
    for cv in curves:
        xs, ys = cv[x].values, cv[y].values
        out.extend(xs[ys == value])
        for i in range(len(xs) - 1):
            if (ys[i] - value) * (ys[i + 1] - value) < 0:
                out.append(xs[i] + (value - ys[i]) / (ys[i + 1] - ys[i]) * (xs[i + 1] - xs[i]))
    return np.unique(np.round(out, 9))


def split_by_curve(chart: xr.Dataset, curves: list[xr.Dataset]) -> dict[str, Counter]:
    """Counts of the chart's classes inside and outside the curves."""
    x, y = chart.attrs["x"], chart.attrs["y"]
    out = {"inside": Counter(), "outside": Counter()}
    for yv in chart[y].values:
        cross = crossings(curves, x, y, float(yv))
        for xv in chart[x].values:
            where = "inside" if np.sum(cross < xv) % 2 else "outside"
            out[where][str(chart.nature.sel({x: xv, y: yv}).item())] += 1
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("chart", type=Path, help="chart of `bearingdyn chart` (netCDF)")
    parser.add_argument("curves", type=Path, nargs="+",
                        help="curves of `bearingdyn curve` (netCDF)")
    parser.add_argument("-o", "--output", type=Path,
                        default=Path("docs/figures/curves-balanced-rotor.png"))
    args = parser.parse_args()
    chart = open_result(args.chart)
    curves = [open_result(path) for path in args.curves]
    for path, cv in zip(args.curves, curves, strict=True):
        p1, p2 = cv.attrs["param1"], cv.attrs["param2"]
        top = int(np.argmax(cv[p2].values))
        print(f"{path.name}: {cv.sizes['point']} points, {cv.attrs['status']}; largest "
              f"{p2} {float(cv[p2][top]):.4f} at {p1} = {float(cv[p1][top]):.2f}")
    for where, counts in split_by_curve(chart, curves).items():
        print(f"{where}: " + ", ".join(f"{k} {n}" for k, n in sorted(counts.items())))
    title = (f"{chart.attrs.get('model', '')}: period-doubling curve (continuation) over a "
             "brute-force stability chart")
    save_figure(curve_figure(curves, chart, title=title), args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
