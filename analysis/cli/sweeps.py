"""Grids of settings: `sweep` (bifurcation diagrams) and `chart` (stability charts)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DtOption,
    ExecutorOption,
    ModelArgument,
    NBallsOption,
    QuietOption,
    SchedulerOption,
    SetOption,
    WorkersOption,
    app,
    netcdf_output,
    parse_n_balls,
    parse_sets,
    reports_errors,
)
from analysis.cli.devices import DeviceOption, SweepDeviceOption
from analysis.cli.plans import run_plan
from analysis.errors import check_count


@app.command()
@reports_errors
def sweep(
    model: ModelArgument,
    param: Annotated[str, typer.Option(
        help="Runtime parameter on the grid, or n_balls (a model with one bearing) / "
             "n_balls[BEARING] (several).")],
    start: Annotated[float, typer.Option("--from", help="First value.")],
    stop: Annotated[float, typer.Option("--to", help="Last value.")],
    num: Annotated[int, typer.Option(help="Number of grid values.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.",
                                         callback=netcdf_output)],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    direction: Annotated[str, typer.Option(help="up, down or both.")] = "up",
    follow: Annotated[bool, typer.Option(
        help="Start each value from the previous value's end state at the same forcing "
             "phase (time carried, scaled by the section period: shows hysteresis); "
             "--no-follow: every value from the spec's initial state at t = 0, in "
             "parallel.")] = True,
    transient: Annotated[float, typer.Option(help="Dropped time per value, s.")] = 1.0,
    samples: Annotated[int, typer.Option(help="Poincaré points per value.")] = 200,
    section: Annotated[str | None, typer.Option(
        help="shaft, cage, vc, cage[BEARING], vc[BEARING] or param:NAME (default: "
             "shaft).")] = None,
    dt: DtOption = None,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    device: SweepDeviceOption = None,
):
    """Brute-force bifurcation diagram over one parameter (resumable: re-run to continue)."""
    from analysis.sweeps.diagram import plan_diagram
    from analysis.sweeps.grid import Axis, Setting

    setting = Setting(model, parse_n_balls(n_balls), parse_sets(sets), transient, samples,
                      section, dt)
    axis = Axis.linear(param, start, stop, num)
    plan = plan_diagram(setting, axis, output, direction=direction, follow=follow,
                        device=device)  # every input, before a worker starts or a file is made
    ds, ran_on = run_plan(plan, executor, workers, scheduler, quiet=quiet,
                           label=f"sweep {param}")
    typer.echo(f"wrote {output}: {ds.sizes[param]} values × {ds.sizes['direction']} "
               f"direction(s), {samples} section points each ({ran_on})")


@app.command()
@reports_errors
def chart(
    model: ModelArgument,
    x: Annotated[str, typer.Option(help="x axis name:start:stop:count, e.g. "
                                        "speed_rpm:1000:10000:200.")],
    y: Annotated[str, typer.Option(help="y axis, e.g. n_balls:5:12 (one bearing) or "
                                        "n_balls[left]:5:12 (several).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.",
                                         callback=netcdf_output)],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    transient: Annotated[float, typer.Option(help="Dropped time per point, s.")] = 1.0,
    revolutions: Annotated[int, typer.Option(
        help="Recorded periods of the section (shaft revolutions by default).")] = 200,
    section: Annotated[str | None, typer.Option(
        help="Section the points are classified on and whose periods are recorded: shaft, "
             "cage, vc, cage[BEARING], vc[BEARING] or param:NAME (default: the model's own "
             "for the class, e.g. vc for a balanced rotor, and shaft revolutions for the "
             "record).")] = None,
    lyapunov: Annotated[bool, typer.Option(help="Largest Lyapunov exponent at every "
                                                "point.")] = True,
    dt: DtOption = None,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    table: Annotated[bool, typer.Option("--table", help="Print the chart as a table.")] = False,
    ics: Annotated[int | None, typer.Option(
        "--ics", help="Also map K initial states per point as one ensemble (the model's own "
                      "and K - 1 drawn in --ics-box): the number of distinct attractors and "
                      "the class of each; multistable points are marked.")] = None,
    ics_box: Annotated[list[str] | None, typer.Option(
        "--ics-box", help="COORD:LO:HI, a side of the box the --ics states are drawn in "
                          "(repeatable; default: every position within ± the radial "
                          "clearance).")] = None,
    ics_seed: Annotated[int, typer.Option(help="Seed of the --ics states.")] = 0,
    device: DeviceOption = "auto",
):
    """Stability chart: periodic-n / quasi-periodic / chaotic on a 2-D grid (resumable)."""
    from analysis.sweeps.chart import chart_table, plan_chart
    from analysis.sweeps.grid import MAX_SAMPLES, Axis, Setting
    from analysis.sweeps.multistability import parse_ics

    check_count("revolutions", revolutions, 1, MAX_SAMPLES)
    setting = Setting(model, parse_n_balls(n_balls), parse_sets(sets), transient, revolutions,
                      section, dt, lyapunov)
    x_axis, y_axis = Axis.parse(x), Axis.parse(y)
    several = parse_ics(ics, ics_box, ics_seed)
    plan = plan_chart(setting, x_axis, y_axis, output, ics=several,
                      device=device)  # every input, before a worker starts or a file is made
    ds, ran_on = run_plan(plan, executor, workers, scheduler, quiet=quiet, label="chart")
    typer.echo(f"wrote {output}: {ds.sizes[ds.attrs['y']]} × {ds.sizes[ds.attrs['x']]} "
               f"points ({ran_on})"
               + (f"; {int(ds.multistable.sum())} multistable among {several.count} initial "
                  "states each" if several is not None else ""))
    if table:
        typer.echo(chart_table(ds))


