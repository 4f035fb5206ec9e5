"""Global dynamics: `basins` (basins of attraction on a grid) and `attractors` (basin
fractions in a box, and their global continuation in a parameter)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    ExecutorOption,
    JsonOption,
    ModelArgument,
    NBallsOption,
    PeriodOption,
    QuietOption,
    SchedulerOption,
    SetOption,
    SpeedOption,
    WorkersOption,
    app,
    echo_json,
    figure_output,
    netcdf_output,
    parameter_values,
    parse_n_balls,
    reports_errors,
    write_figure,
)
from analysis.cli.devices import DeviceOption
from analysis.cli.plans import run_plan

DtOption = Annotated[float | None, typer.Option(
    help="Largest RK4 step, s (default: the spec's); the map takes N = ceil(T/dt) steps "
         "per forcing period T.")]
ResolutionOption = Annotated[int, typer.Option(
    help="Cells per orbit size along each coordinate (coarser merges close attractors, "
         "finer costs periods).")]
RevisitsOption = Annotated[int, typer.Option(
    help="Consecutive revisits of a trajectory's own cells that mark an attractor.")]
RecordOption = Annotated[int, typer.Option(help="Section points recorded per new attractor.")]
HitsOption = Annotated[int, typer.Option(
    help="Consecutive points in a known attractor's cells that label a trajectory.")]
MaxPeriodsOption = Annotated[int, typer.Option(
    help="Forcing periods after which a trajectory still searching is 'undecided'.")]
PlotOption = Annotated[Path | None, typer.Option(
    "--plot", help="Figure to write (PNG, PDF, SVG).", callback=figure_output)]
OutputOption = Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.",
                                            callback=netcdf_output)]
BlockOption = Annotated[int | None, typer.Option(
    "--block", help="Initial states per block: each block is mapped by its own mapper on one "
                    "worker and stored in OUTPUT.parts as it finishes (an interrupted run "
                    "resumes); the result depends on it, not on the executor (default: 256 "
                    "for the recurrence mapper, 65536 on the CPU and 1048576 on a GPU for "
                    "the featurizing one).")]
MapperOption = Annotated[str, typer.Option(
    "--mapper", help="recurrence (each trajectory until its cells recur; stops early), "
                     "features (every state run a fixed time on the member kernel, then "
                     "clustered by section-point features) or auto (features from 100000 "
                     "states or on a GPU).")]
TransientPeriodsOption = Annotated[int, typer.Option(
    "--transient-periods", help="Featurizing mapper: forcing periods run before the "
                                "section points are recorded.")]
SectionsOption = Annotated[int, typer.Option(
    "--sections", help="Featurizing mapper: section points recorded per state.")]


def _system(model: str, n_balls, speed_rpm, sets):
    from analysis.model import System

    return System.make(model, parse_n_balls(n_balls), **parameter_values(speed_rpm, sets))


def _options(resolution: int, revisits: int, record: int, hits: int, max_periods: int):
    from analysis.stability.attractors import MapperOptions

    return MapperOptions(resolution=resolution, revisits=revisits, record=record, hits=hits,
                         max_periods=max_periods)


def _mapping(mapper: str, device: str, transient_periods: int, sections: int) -> dict:
    """The mapper's settings as keywords of the studies."""
    from analysis.stability.attractors.featurizing import FeatureOptions

    return dict(mapper=mapper, device=device,
                feature_options=FeatureOptions(transient=transient_periods, sections=sections))


def _finish(ds, output: Path, as_json: bool, plot: Path | None, branches=()) -> None:
    """Print the table or the JSON (the file is written), draw the figure."""
    from analysis.stability.attractors import study_json

    if as_json:
        echo_json(study_json(ds), indent=2)
    else:
        _echo_table(ds, output)
    if plot:
        from analysis.reports.attractor_plots import study_figure

        write_figure(study_figure(ds, branches), plot, err=as_json)


def _echo_table(ds, output: Path) -> None:
    """One line per attractor: id, class, basin fraction, λ1, amplitudes; then the
    boundary measures (basins) and, when states did not settle, why and what to raise. A
    continuation: each attractor's range, the fractions (± standard error) at every value,
    where each basin's states go at the next value, and the doubts about the matches."""
    from analysis.stability.attractors.dataset import unsettled

    if ds.attrs["kind"] == "attractor-continuation":
        _echo_continuation(ds, output)
        return
    found = int((ds.attractor.values > 0).sum())
    typer.echo(f"wrote {output}: {found} attractor(s) on the {ds.attrs['section']} section")
    names = [str(s) for s in ds.state.values][: max(1, ds.sizes["state"] // 2)]
    for i in ds.attractor.values:
        row = ds.sel(attractor=i)
        head = f"  {int(i):>2}  {row.nature.values!s:<15} " \
               f"{100 * float(row.fraction):5.1f} % ± {100 * float(row.fraction_stderr):.1f}"
        if int(i) > 0:
            amp = ", ".join(f"{k} {float(row.amplitude.sel(state=k)):.4g} {unit}"
                            for k, unit in zip(names, ds.state_units.values, strict=False))
            head += (f"  λ1 = {float(row.lambda1):.4g} ± {float(row.lambda1_ci95):.2g} 1/s"
                     f"  amplitude {amp}")
        typer.echo(head)
    if "basin_entropy" in ds.attrs and float(ds.attrs["boundary_boxes"]) == 0:
        typer.echo("  boundary: none on this grid (every box of "
                   f"{int(ds.attrs['entropy_box'])} cells holds one label)")
    elif "basin_entropy" in ds.attrs:
        a = ds.attrs
        fractal = " (> ln 2: the boundary is fractal)" \
            if float(a["boundary_basin_entropy"]) > 0.6931471805599453 else ""
        typer.echo(f"  boundary: basin entropy {float(a['basin_entropy']):.3g}, boundary "
                   f"basin entropy {float(a['boundary_basin_entropy']):.3g} nats"
                   f"{fractal} ({int(a['entropy_box'])}-cell boxes, "
                   f"{100 * float(a['boundary_boxes']):.1f} % on a boundary); uncertainty "
                   f"exponent {_exponent(float(a['uncertainty_exponent']))}"
                   + _edges(a))
    for line in unsettled(ds):
        typer.echo(f"  {line}")


def _edges(attrs) -> str:
    """'; with the edge states too: α' (the exponent over every state), or ''."""
    import math

    alpha = float(attrs.get("uncertainty_exponent_edges", math.nan))
    return f"; {alpha:.3g} with the edge states too" if math.isfinite(alpha) else ""


def _exponent(alpha: float) -> str:
    """The uncertainty exponent as the text says it."""
    import math

    if math.isnan(alpha):
        return "not measured (the grid is too small for two values of ε)"
    return (f"{alpha:.3g} over interior states only, those whose four neighbours ε cells "
            "away lie on the grid (1: smooth boundary, < 1: fractal, near 0: riddled)")


def _echo_continuation(ds, output: Path) -> None:
    """The text of an attractor continuation (see ``_echo_table``)."""
    from analysis.stability.attractors import existence
    from analysis.stability.attractors.dataset import transition_json

    param = ds.attrs["param"]
    typer.echo(f"wrote {output}: attractors at {ds.sizes['value']} values of {param}")
    for i, (low, high) in existence(ds).items():
        natures = sorted({str(n) for n in ds.nature.sel(attractor=i).values if str(n)})
        typer.echo(f"  attractor {i} ({', '.join(natures)}): {param} from {low:g} to "
                   f"{high:g}")
    typer.echo(f"  basin fractions (% ± standard error, {int(ds.attrs['samples'])} states "
               "per value) and where each basin's states go at the next value:")
    for k, value in enumerate(ds.value.values):
        here = ds.isel(value=k)
        shares = ", ".join(
            f"{_label(ds, int(i))} {100 * float(here.fraction.sel(attractor=i)):.1f} ± "
            f"{100 * float(here.fraction_stderr.sel(attractor=i)):.1f}"
            for i in ds.attractor.values[here.present.values])
        typer.echo(f"    {value:g}: {shares or 'none'}")
        notes = str(ds.match_notes.values[k]) if "match_notes" in ds else ""
        for note in filter(None, notes.split("\n")):
            typer.echo(f"      warning (matched from {ds.value.values[k - 1]:g}): {note}")
        moves = transition_json(ds, k)
        if moves and k + 1 < ds.sizes["value"]:
            text = "; ".join(f"{_label(ds, int(a))} → " + ", ".join(
                f"{_label(ds, int(b))} {p:.2f}" for b, p in row.items())
                for a, row in moves.items())
            typer.echo(f"      to {ds.value.values[k + 1]:g}: {text}")


def _label(ds, i: int) -> str:
    """An id as the text names it: the number, or diverged/undecided/failed."""
    from analysis.stability.attractors.mapper import SPECIAL_LABELS

    return SPECIAL_LABELS[i] if i < 0 else str(i)


@app.command()
@reports_errors
def basins(
    model: ModelArgument,
    x: Annotated[str, typer.Option(
        "--x", help="COORD:LO:HI:N: a state (x, vy, x_housing …) from LO to HI in its unit, "
                    "N grid values.")],
    y: Annotated[str, typer.Option("--y", help="COORD:LO:HI:N, the other state.")],
    output: OutputOption,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    dt: DtOption = None,
    resolution: ResolutionOption = 40,
    revisits: RevisitsOption = 30,
    record: RecordOption = 100,
    hits: HitsOption = 5,
    max_periods: MaxPeriodsOption = 3000,
    block: BlockOption = None,
    mapper: MapperOption = "auto",
    device: DeviceOption = "auto",
    transient_periods: TransientPeriodsOption = 200,
    sections: SectionsOption = 48,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    as_json: JsonOption = False,
    plot: PlotOption = None,
    quiet: QuietOption = False,
):
    """Basins of attraction: the attractor reached from every initial state of a grid over
    two state coordinates (the others at the model's initial state), and every attractor's
    class, period, λ1 and amplitudes. Resumable: re-run the same command to continue."""
    from analysis.stability.attractors import Range
    from analysis.sweeps.attractor_blocks import plan_basins

    x_range = Range.parse(x, "--x", with_num=True)
    y_range = Range.parse(y, "--y", with_num=True)
    options = _options(resolution, revisits, record, hits, max_periods)
    system = _system(model, n_balls, speed_rpm, sets)
    # every input, before any work or file; the device judged once, the study made once
    plan = plan_basins(system, x_range, y_range, output, period=period, dt=dt,
                       options=options, block=block,
                       **_mapping(mapper, device, transient_periods, sections))
    ds, _ = run_plan(plan, executor, workers, scheduler, quiet=quiet or as_json,
                     part="block")
    _finish(ds, output, as_json, plot)


@app.command()
@reports_errors
def attractors(
    model: ModelArgument,
    samples: Annotated[int, typer.Option(help="Random initial states (per value with "
                                              "--param).")],
    box: Annotated[list[str], typer.Option(
        "--box", help="COORD:LO:HI: a side of the box of initial states (repeatable); the "
                      "other states at the model's initial state.")],
    output: OutputOption,
    param: Annotated[str | None, typer.Option(
        "--param", help="NAME:LO:HI:N: continue the attractors over N values of a runtime "
                        "parameter (its own unit, rpm for speed_rpm).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the random initial states.")] = 0,
    match_distance: Annotated[float | None, typer.Option(
        "--match-threshold", help="With --param: largest distance between the section "
                                  "points of two attractors at consecutive values, in orbit "
                                  "sizes, that still makes them one id; larger matches are "
                                  "warned about (default 0.25).")] = None,
    branch: Annotated[list[Path] | None, typer.Option(
        "--branch", help="Continuation branch file(s) (`bearingdyn continue`) drawn on the "
                         "--param figure.")] = None,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    dt: DtOption = None,
    resolution: ResolutionOption = 40,
    revisits: RevisitsOption = 30,
    record: RecordOption = 100,
    hits: HitsOption = 5,
    max_periods: MaxPeriodsOption = 3000,
    block: BlockOption = None,
    mapper: MapperOption = "auto",
    device: DeviceOption = "auto",
    transient_periods: TransientPeriodsOption = 200,
    sections: SectionsOption = 48,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    as_json: JsonOption = False,
    plot: PlotOption = None,
    quiet: QuietOption = False,
):
    """Every attractor and its basin fraction (± standard error) among random initial
    states in a box; with --param, their global continuation: found at each value from the
    previous value's attractors and new random states (the blocks of each value on the
    executor), matched across values. Resumable: re-run the same command to continue."""
    from analysis.stability.attractors import Box, Range
    from analysis.sweeps.attractor_blocks import (
        check_branch_of,
        plan_continuation,
        plan_fractions,
    )

    sides = Box.parse(box, "--box")
    options = _options(resolution, revisits, record, hits, max_periods)
    along = Range.parse(param, "--param", with_num=True) if param is not None else None
    match_distance = _threshold(along, match_distance)
    branches = [_branch(path) for path in branch or []]
    if branches and along is None:
        raise _input_error("--branch: a branch is drawn on the --param figure; give --param")
    system = _system(model, n_balls, speed_rpm, sets)
    for path, drawn in zip(branch or [], branches, strict=True):
        check_branch_of(system, drawn, along.coordinate, f"--branch '{path}'")
    settings = dict(seed=seed, period=period, dt=dt, options=options, block=block,
                    **_mapping(mapper, device, transient_periods, sections))
    if along is None:  # every input checked once: the plan
        plan = plan_fractions(system, sides, samples, output, **settings)
        ds, _ = run_plan(plan, executor, workers, scheduler, quiet=quiet or as_json,
                      part="block")
    else:
        plan = plan_continuation(system, along.coordinate, along.points, sides, samples,
                                 output, **settings, match_distance=match_distance)
        ds, _ = run_plan(plan, executor, workers, scheduler, quiet=quiet, part="block",
                      lines=True, cost=not as_json)
    _finish(ds, output, as_json, plot, branches)


def _threshold(along, match_distance: float | None) -> float | None:
    """The matching threshold of a continuation over ``along`` (default
    ``MATCH_DISTANCE``; checked by the plan, whose refusal names ``--match-threshold``:
    ``common.as_option``); given without --param it is refused (it was ignored)."""
    from analysis.stability.attractors.continuation import MATCH_DISTANCE
    from analysis.sweeps.attractor_blocks import check_value_count

    if along is None:
        if match_distance is not None:
            raise _input_error("--match-threshold: matches attractors between consecutive "
                               "--param values; give --param NAME:LO:HI:N, or leave it out")
        return None
    check_value_count("--param", along.num)  # before its values are made
    return MATCH_DISTANCE if match_distance is None else match_distance


def _input_error(text: str):
    from analysis.errors import InputError

    return InputError(text)


def _branch(path: Path):
    """A continuation branch file, read and checked before any work."""
    from analysis.io import open_result

    ds = open_result(path)
    if "special" not in ds or "param" not in ds.attrs:
        raise _input_error(f"--branch: '{path}' is not a branch of `bearingdyn continue`")
    return ds
