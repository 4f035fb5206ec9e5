"""`bearingdyn curve`: fold, period-doubling and Neimark–Sacker curves in two parameters."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DsMaxOption,
    MaxPointsOption,
    QuietOption,
    app,
    figure_output,
    netcdf_output,
    progress_lines,
    reports_errors,
    write_figure,
)


@app.command("curve")
@reports_errors
def curve(
    branch: Annotated[Path, typer.Argument(
        help="Branch file of `bearingdyn continue` (netCDF).", metavar="BRANCH.nc")],
    point: Annotated[str, typer.Option(
        help="The branch's point to follow: LP, PD or NS, the k-th with LP[k] (k = 1, 2, … "
             "along the branch; default the first).")],
    param: Annotated[str, typer.Option(help="Second runtime parameter to vary.")],
    stop: Annotated[float, typer.Option(
        "--to", help="End value of --param (its unit); it starts at the branch's value.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the curve.",
                                         callback=netcdf_output)],
    max_points: MaxPointsOption = 300,
    ds_max: DsMaxOption = 0.05,
    chart: Annotated[Path | None, typer.Option(
        help="Stability chart (`bearingdyn chart`) over the same two parameters, drawn "
             "under the curve in --plot.")] = None,
    plot: Annotated[Path | None, typer.Option(help="Figure of the curve (PNG).",
                                              callback=figure_output)] = None,
    quiet: QuietOption = False,
):
    """Two-parameter continuation of an LP, PD or NS point; labels cusps (CP), strong
    resonances (R1-R4) and fold-flip/fold-NS/flip-NS points."""
    from analysis.io import open_result, save_dataset
    from analysis.stability.curves import continue_curve, special_lines

    chart_ds = open_result(chart) if chart else None
    if chart_ds is not None and chart_ds.attrs.get("kind") != "chart":
        from analysis.errors import InputError

        raise InputError(f"chart: {chart} is not a stability chart of `bearingdyn chart`")
    ds = continue_curve(branch, point, param=param, stop=stop,
                        max_points=max_points, ds_max=ds_max,
                        progress=progress_lines(quiet, err=False))
    save_dataset(ds, output)
    typer.echo(f"wrote {output}: {ds.sizes['point']} points of the {ds.attrs['curve']} curve "
               f"in {ds.attrs['param1']} and {ds.attrs['param2']}, {ds.attrs['status']}")
    lines = special_lines(ds)
    for line in lines:
        typer.echo(line)
    if not lines:
        typer.echo("no codimension-two points on the curve")
    if plot:
        from analysis.reports.curve_plots import curve_figure

        write_figure(curve_figure([ds], chart_ds), plot)
