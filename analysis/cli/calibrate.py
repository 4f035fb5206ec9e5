"""`calibrate`: which values of unknown parameters make a model reproduce a table of
regimes and spectrum lines (approximate Bayesian computation, ``analysis.inference``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    ExecutorOption,
    JsonOption,
    ModelArgument,
    QuietOption,
    SchedulerOption,
    WorkersOption,
    app,
    echo_json,
    figure_output,
    netcdf_output,
    reports_errors,
    write_figure,
)
from analysis.cli.plans import run_plan


@app.command()
@reports_errors
def calibrate(
    model: ModelArgument,
    target: Annotated[str, typer.Option(
        "--target", help="A built-in target (paper-table2, paper-table2-torus) or a target "
                         "TOML file "
                         "(docs: Which parameters did the paper use?).")],
    prior: Annotated[list[str], typer.Option(
        "--prior", help="NAME:LO:HI or NAME:LO:HI:log, a calibrated parameter's uniform "
                        "(log-uniform) prior in SI units; repeat for each.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.",
                                         callback=netcdf_output)],
    samples: Annotated[int, typer.Option(help="Parameter sets per round.")] = 200,
    rounds: Annotated[int, typer.Option(
        help="Rounds: a Sobol round, then SMC-ABC rounds of shrinking tolerance.")] = 3,
    seed: Annotated[int, typer.Option(help="Seed of the Sobol scramble and the rounds.")] = 0,
    device: Annotated[str, typer.Option(
        help="cpu, gpu or auto (the member kernels' CUDA build).")] = "cpu",
    transient: Annotated[int, typer.Option(
        "--transient-revolutions", help="Shaft revolutions dropped per member.")] = 50,
    revolutions: Annotated[int, typer.Option(
        help="Shaft revolutions recorded per member (a multiple of 10).")] = 100,
    dt: Annotated[float | None, typer.Option(
        "--dt", help="Largest RK4 step, s (default: the spec's).")] = None,
    block: Annotated[int | None, typer.Option(
        help="Parameter sets per executor task (default: 64 on cpu, a round on gpu).")] = None,
    executor: ExecutorOption = "serial",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    as_json: JsonOption = False,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Corner figure to write (PNG, PDF, SVG).",
        callback=figure_output)] = None,
    quiet: QuietOption = False,
):
    """Calibrate unknown parameters against a target table (SMC-ABC; resumable)."""
    from analysis.inference.results import plan_calibration, to_dataset, to_json
    from analysis.inference.simulate import RunSettings

    plan = plan_calibration(model, target, prior, output, samples=samples, rounds=rounds,
                            seed=seed, device=device, block=block,
                            settings=RunSettings(transient_revolutions=transient,
                                                 revolutions=revolutions, dt=dt))
    run_plan(plan, executor, workers, scheduler, quiet=quiet, part="block")
    cal = plan.calibration
    if as_json:
        echo_json(to_json(cal, str(output)), indent=1)
    else:
        _print(cal, output)
    if plot:
        from analysis.reports.calibration_plots import corner_figure

        write_figure(corner_figure(to_dataset(cal)), plot, err=as_json)


def _print(cal, output: Path) -> None:
    """The answer, what is doubtful in it, how far it narrowed the prior, and whether it
    can conclude."""
    doubtful = cal.doubtful_share()
    shares = ", ".join(f"{k}: {v:.3g}" + (f" (+{doubtful[k]:.3g} doubtful)" if doubtful[k]
                                          else "")
                       for k, v in cal.share_of_prior().items())
    typer.echo(f"wrote {output}: best {cal.best_matched()} of {len(cal.target.rows)} rows; "
               f"share of the prior matching k rows: {shares}")
    typer.echo("  (doubtful: the class would match but lambda1's 95 % interval reaches "
               "zero, or it changed with the step halved; not counted as matched)")
    if cal.halved is not None:
        typer.echo(f"  step halved at the best sets: {cal.halved[1]} of {cal.halved[0]} "
                   "matched rows changed class")
    narrowing = cal.narrowing()
    for name, (lo, hi) in cal.credible_interval(0.9).items():
        unit = cal.model.units.get(name, "")
        typer.echo(f"  {name}: 90 % credible interval {lo:.4g} to {hi:.4g} {unit}, "
                   f"{narrowing[name]:.0%} of the prior's width")
    typer.echo(f"  effective sample size {cal.effective_sample_size():.0f} of "
               f"{len(cal.posterior.values)} sets")
    verdict = cal.verdict()
    if verdict:
        typer.echo(f"too small to conclude: {verdict}; give more --samples or --rounds")

