"""`bearingdyn explore`: a stability chart as one self-contained HTML page."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    ExecutorOption,
    QuietOption,
    SchedulerOption,
    WorkersOption,
    app,
    executor_of,
    html_output,
    reports_errors,
)


@app.command()
@reports_errors
def explore(
    chart_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn chart`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="HTML file to write.",
                                         callback=html_output)],
    spectrum_bins: Annotated[int, typer.Option(
        help="Spectrum bins kept per variable (the largest of each group: no peak lost).")
    ] = 400,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
):
    """Chart explorer: one HTML page (no network needed) where clicking a point of the
    stability chart shows its spectra, Poincaré maps and numbers. Each point's run is
    recomputed for it (one simulation per point, without the Lyapunov exponent)."""
    from analysis.reports.explorer import check_spectrum_bins, load_chart, write_explorer
    from analysis.reports.progress import ProgressReporter

    check_spectrum_bins(spectrum_bins)
    chart = load_chart(chart_file)  # judged before a worker starts
    ex = executor_of(executor, workers, scheduler)
    progress = ProgressReporter("explore: recomputing each point's run", quiet, after=2.0)
    progress(0, chart.sizes[chart.attrs["x"]] * chart.sizes[chart.attrs["y"]])  # at once
    try:
        path = write_explorer(chart, output, spectrum_bins=spectrum_bins, executor=ex,
                              progress=progress)
    finally:
        ex.close()
    typer.echo(f"wrote {path} ({path.stat().st_size / 1e3:.0f} kB, {ex.name})")
