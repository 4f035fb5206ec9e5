"""The paper's job: `reproduce`, `run`, and the `bench` benchmark."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    ExecutorOption,
    ModelOption,
    QuietOption,
    SchedulerOption,
    SetOption,
    WorkersOption,
    app,
    check_out_dir,
    executor_of,
    parse_sets,
    reports_errors,
)
from analysis.errors import InputError


@app.command()
@reports_errors
def reproduce(
    model: Annotated[str, typer.Argument(help="The paper's model.")] = "vakharia2015",
    out_dir: Annotated[Path, typer.Option("-o", "--out-dir", help="Report folder.")] = Path(
        "bearingdyn-reproduction"),
    quick: Annotated[bool, typer.Option(
        "--quick", help="Short runs and two values per sensitivity parameter (a smoke test; "
                        "verdicts less reliable).")] = False,
    calibrated: Annotated[str | None, typer.Option(
        "--calibrated", help="A calibrated model to classify beside MODEL at every N_b (e.g. "
                             "vakharia2015-calibrated): the report's classes in three "
                             "columns, paper / MODEL / calibrated.")] = None,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
):
    """Reproduce the paper: Table 2 and Figs. 2-6 side by side with the paper, sensitivity
    to the omitted parameters, provenance (report.md, report.html, table2.json)."""
    from analysis.reports.paper import SENSITIVITY
    from analysis.reports.progress import ProgressReporter
    from analysis.reports.report import write_reproduction
    from analysis.reports.reproduce import check_reproduction
    from analysis.reports.reproduce import reproduce as run_reproduce

    check_out_dir(out_dir)
    kwargs = {}
    if quick:
        kwargs = dict(duration=1.6, transient=0.6, revolutions=60,
                      sensitivity={k: (min(v), max(v)) for k, v in SENSITIVITY.items()})
    check_reproduction(model, **kwargs)  # every input, before a worker starts or a file is made
    if calibrated is not None:
        check_reproduction(calibrated, **{**kwargs, "sensitivity": {}})
    ex = executor_of(executor, workers, scheduler)
    try:
        rep = run_reproduce(out_dir, model, executor=ex, log=None if quiet else typer.echo,
                            progress_factory=lambda label: ProgressReporter(label, quiet),
                            quick=quick, calibrated=calibrated, **kwargs)
    finally:
        ex.close()
    paths = write_reproduction(rep, out_dir)
    typer.echo(f"wrote {paths['markdown']}, {paths['html']}, {paths['json']} "
               f"({rep.wall_s:.0f} s)")


@app.command()
@reports_errors
def run(
    out_dir: Annotated[Path, typer.Option("-o", "--out-dir", help="Output folder.")] = Path(
        "bearingdyn-out"),
    model: ModelOption = "vakharia2015",
    n_balls: Annotated[list[int] | None, typer.Option(
        help="Numbers of balls (repeatable; default 6 7 8 9 10).")] = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time, s.")] = None,
    transient: Annotated[float | None, typer.Option(help="Dropped initial time, s.")] = None,
    sets: SetOption = None,
):
    """The default job: the paper's case for N_b = 6…10 (netCDF + figure per N_b, peak table)."""
    from analysis.integrate.simulate import check_run
    from analysis.reports.paper import PAPER_N_BALLS, check_one_bearing
    from analysis.reports.report import explanation_note, peak_table_markdown, run_paper_case

    params = parse_sets(sets)
    check_out_dir(out_dir)
    if not n_balls:
        check_one_bearing(model, "--model", "the paper's case (N_b = 6…10)")
    for nb in n_balls or PAPER_N_BALLS:  # every run checked before the first file is written
        check_run(model, nb, duration=duration, transient=transient, **params)
    results = run_paper_case(out_dir, model, n_balls or PAPER_N_BALLS, duration, transient,
                             progress=typer.echo, **params)
    typer.echo("\n" + peak_table_markdown(results) + explanation_note(results))
    typer.echo(f"results in {out_dir}/ (nb<N>.nc, nb<N>.png, peaks.md, peaks.json)")


@app.command()
@reports_errors
def bench(
    repeat: Annotated[int, typer.Option(help="Runs per path; the table shows medians.")] = 5,
    duration: Annotated[float, typer.Option(help="Simulated time of the timed run, s.")] = 1.0,
    memory_duration: Annotated[float, typer.Option(
        help="Simulated time of the peak-memory run, s (0: skip).")] = 100.0,
):
    """Speed and memory benchmark (about 2 min): compiled RK4, CasADi VM, NumPy, SciPy, numba.

    The benchmark is ``analysis.reports.bench`` (``benchmarks/bench_simulate.py`` of a source
    checkout runs the same).
    """
    if repeat < 1:
        raise InputError(f"--repeat: must be >= 1, got {repeat}")
    if not duration > 0 or memory_duration < 0:
        raise InputError(f"--duration: must be > 0 s and --memory-duration >= 0 s, got "
                         f"{duration:g} and {memory_duration:g}")
    from analysis.reports.bench import format_result, run_benchmark

    res = run_benchmark(repeat, duration, memory_duration,
                        progress=lambda msg: typer.echo(msg, err=True))
    typer.echo(format_result(res))
