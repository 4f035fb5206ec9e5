"""`bearingdyn continue`: branches of periodic orbits."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from analysis.cli.common import (
    ModelArgument,
    NBallsOption,
    PeriodOption,
    SetOption,
    _given,
    _save_figure,
    app,
    parse_n_balls,
    parse_sets,
    reports_errors,
)


@app.command("continue")
@reports_errors
def continue_(
    model: ModelArgument,
    param: Annotated[str, typer.Option(help="Runtime parameter to vary.")],
    start: Annotated[float, typer.Option("--from", help="Start value (parameter unit).")],
    stop: Annotated[float, typer.Option("--to", help="End value (parameter unit).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the branch.")],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    dt: Annotated[float | None, typer.Option(
        help="Largest RK4 step, s (default: the spec's).")] = None,
    settle: Annotated[float, typer.Option(help="Simulated time for the first guess, s.")] = 0.5,
    max_points: Annotated[int, typer.Option(help="Points per branch.")] = 200,
    ds_max: Annotated[float, typer.Option(help="Largest scaled arclength step.")] = 0.05,
    switch_pd: Annotated[bool, typer.Option(
        "--switch-pd", help="Also continue the period-2 branch from the first PD.")] = False,
    plot: Annotated[Path | None, typer.Option(help="Figure of the branch(es).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
):
    """Pseudo-arclength continuation of periodic orbits; LP, PD, NS, BP detection."""
    from analysis.io import save_dataset
    from analysis.stability import continuation as cont

    progress = None if quiet else typer.echo
    branch = cont.continue_orbits(model, parse_n_balls(n_balls), param=param, start=start,
                                  stop=stop, period=period, settle=settle,
                                  max_points=max_points, ds_max=ds_max, progress=progress,
                                  **_given(dt=dt), **parse_sets(sets))
    branches = [branch]
    if switch_pd:
        pds = np.nonzero(branch.special.values == "PD")[0]
        if len(pds) == 0:
            typer.echo("no period doubling on the branch: nothing to switch to", err=True)
        else:
            two = cont.switch_period_doubling(branch, int(pds[0]), dt=None)
            if not two.converged:
                typer.echo(f"branch switching failed: {two.message}", err=True)
            else:
                branches.append(cont.continue_from_orbit(
                    two, param=param, stop=stop, max_points=max_points, ds_max=ds_max,
                    progress=progress, label=f"period {two.period}", **_given(dt=dt)))
    for i, br in enumerate(branches):
        path = output if i == 0 else output.with_name(f"{output.stem}-period2{output.suffix}")
        save_dataset(br, path)
        specials = [f"{k} at {br[param].values[j]:.6g}" for j, k in
                    enumerate(br.special.values) if k]
        typer.echo(f"wrote {path}: {br.sizes['point']} orbits ({br.attrs['branch']}), "
                   f"{br.attrs['status']}; special points: {', '.join(specials) or 'none'}")
    if plot:
        from analysis.reports.plots import branch_figure

        _save_figure(branch_figure(branches), plot)
