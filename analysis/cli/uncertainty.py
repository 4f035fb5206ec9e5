"""`uncertainty`: the probability of each regime under manufacturing tolerances, with its
intervals, and which tolerance matters most (Sobol' indices; ``analysis.uncertainty``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DtOption,
    ExecutorOption,
    JsonOption,
    ModelArgument,
    QuietOption,
    SchedulerOption,
    SetOption,
    WorkersOption,
    app,
    echo_json,
    figure_output,
    netcdf_output,
    parse_sets,
    reports_errors,
    write_figure,
)
from analysis.cli.devices import DeviceOption
from analysis.errors import InputError


def parse_balls_list(text: str) -> list[int]:
    """``7,8,9`` or ``5:12`` (every whole number from low to high) -> counts."""
    try:
        if ":" in text:
            low, high = (int(p) for p in text.split(":"))
            if high < low:
                raise ValueError
            return list(range(low, high + 1))
        return [int(p) for p in text.split(",") if p.strip()]
    except ValueError:
        raise InputError(f"--n-balls: expected a list 7,8,9 or a range LOW:HIGH, "
                         f"got {text!r}") from None


def swept(param: str | None, n_balls: str | None) -> dict:
    """The swept axis as ``prepare`` takes it: ``param`` or ``n_balls``."""
    from analysis.sweeps.grid import Axis

    balls = None if n_balls is None else parse_balls_list(n_balls)
    if param is None and balls is None:
        raise InputError("--param/--n-balls: give one of them (--param NAME:LO:HI:N, or "
                         "--n-balls LIST)")
    if param is None:
        return {"n_balls": balls}
    axis = Axis.parse(param)
    if axis.structural:
        raise InputError("--param: sweep the balls with --n-balls LIST")
    return {"param": (axis.name, axis.values), "n_balls": balls}


@app.command()
@reports_errors
def uncertainty(
    model: ModelArgument,
    dist: Annotated[list[str], typer.Option(
        "--dist", help="NAME=uniform:LO:HI, NAME=normal:MEAN:SD or "
                       "NAME=lognormal:MEDIAN:FACTOR (SI units), an uncertain parameter; "
                       "repeat for each.")],
    samples: Annotated[int, typer.Option(
        help="Base draws N (Sobol'): N (P + 2) members per value for P uncertain "
             "parameters, 2N of them independent for the probabilities.")],
    param: Annotated[str | None, typer.Option(
        help="Swept parameter NAME:LO:HI:N (e.g. speed_rpm:4000:8000:5).")] = None,
    n_balls: Annotated[str | None, typer.Option(
        "--n-balls", help="Swept balls: a list 7,8,9 or a range 5:12 (with --param: one "
                          "count, the balls of the sweep).")] = None,
    sets: SetOption = None,
    seed: Annotated[int, typer.Option(help="Seed of the Sobol' scramble.")] = 0,
    device: DeviceOption = "cpu",
    transient: Annotated[int, typer.Option(
        "--transient-revolutions", help="Shaft revolutions dropped per member.")] = 50,
    revolutions: Annotated[int, typer.Option(
        help="Shaft revolutions recorded per member (a multiple of 10).")] = 100,
    dt: DtOption = None,
    block: Annotated[int | None, typer.Option(
        help="Members per executor task (default: 256 on cpu, a value's draws on gpu).")
    ] = None,
    executor: ExecutorOption = "serial",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="netCDF file to write (resumable: run again to continue).",
        callback=netcdf_output)] = None,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Figure to write (PNG, PDF, SVG): stacked regime probabilities and "
                       "Sobol' indices.", callback=figure_output)] = None,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
):
    """Regime probabilities under tolerances, with intervals and Sobol' indices."""
    from analysis.cli.plans import run_plan
    from analysis.inference.simulate import RunSettings
    from analysis.uncertainty.study import plan_uncertainty, to_json

    plan = plan_uncertainty(model, dist, output, sets=parse_sets(sets),
                            **swept(param, n_balls), samples=samples, seed=seed,
                            device=device, block=block,
                            settings=RunSettings(transient_revolutions=transient,
                                                 revolutions=revolutions, dt=dt))
    ds, _ = run_plan(plan, executor, workers, scheduler, quiet=quiet, part="block")
    if as_json:
        echo_json(to_json(ds, str(output or "")), indent=1)
    else:
        _print(ds, output)
    if plot:
        from analysis.reports.uncertainty_plots import uncertainty_figure

        write_figure(uncertainty_figure(ds), plot, err=as_json)


def _print(ds, output: Path | None) -> None:
    """Per value: each regime's probability and interval, and the parameter P(chaos) is
    most sensitive to (the largest total Sobol' index)."""
    import numpy as np

    axis = ds.attrs["axis"]
    if output is not None:
        typer.echo(f"wrote {output}")
    names = [str(n) for n in ds["parameter"].values]
    for i, v in enumerate(ds[axis].values):
        parts = [f"{g} {ds['probability'].values[i, k]:.3f} "
                 f"[{ds['probability_ci95'].values[i, k, 0]:.3f}, "
                 f"{ds['probability_ci95'].values[i, k, 1]:.3f}]"
                 for k, g in enumerate(ds["regime"].values)]
        st = ds["sobol_chaotic_ST"].values[i]
        most = "" if np.all(np.isnan(st)) else \
            (f"; P(chaos) most sensitive to {names[int(np.nanargmax(st))]} "
             f"(ST {np.nanmax(st):.2f})")
        typer.echo(f"{axis} = {v:g}: " + ", ".join(parts) + most)

