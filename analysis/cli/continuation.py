"""`bearingdyn continue`: branches of periodic orbits."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DsMaxOption,
    DtOption,
    FromOption,
    JsonOption,
    MaxPointsOption,
    NBallsOption,
    ParamOption,
    PeriodOption,
    QuietOption,
    SetOption,
    SettleOption,
    app,
    echo_json,
    figure_output,
    given_options,
    judge_spec,
    netcdf_output,
    parse_n_balls,
    parse_sets,
    reports_errors,
    write_figure,
)
from analysis.errors import InputError

SWITCH_SUFFIX = {"PD": "period2", "BP": "asymmetric"}
"""File name suffix of the branch switched to at the first PD / BP point."""


@app.command("continue")
@reports_errors
def continue_(
    stop: Annotated[float, typer.Option("--to", help="End value (parameter unit).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the branch.",
                                         callback=netcdf_output)],
    model: Annotated[str | None, typer.Argument(
        metavar="MODEL",
        help="Model: a shipped name, a name in a BEARINGDYN_MODELS folder, a .toml spec or a "
             "generated folder (not with --from-branch).", callback=judge_spec,
        is_eager=True)] = None,
    param: ParamOption = None,
    start: FromOption = None,
    from_branch: Annotated[Path | None, typer.Option(
        "--from-branch", help="Continue from a point of this branch file instead (its model, "
                              "parameters, period and step; either direction).")] = None,
    point: Annotated[int, typer.Option(
        help="The point of --from-branch to start from (negative: from the end).")] = -1,
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    dt: DtOption = None,
    settle: SettleOption = None,
    max_points: MaxPointsOption = 200,
    ds_max: DsMaxOption = 0.05,
    switch_pd: Annotated[bool, typer.Option(
        "--switch-pd", help="Also continue the period-2 branch from the first PD.")] = False,
    switch_bp: Annotated[bool, typer.Option(
        "--switch-bp", help="Also continue the asymmetric branch from the first BP "
                            "(symmetry-breaking pitchfork).")] = False,
    plot: Annotated[Path | None, typer.Option(help="Figure of the branch(es).",
                                              callback=figure_output)] = None,
    quiet: QuietOption = False,
    as_json: JsonOption = False,
):
    """Pseudo-arclength continuation of periodic orbits; LP, PD, NS, BP detection; every
    step guarded against jumps to another branch."""

    def say(text: str) -> None:
        typer.echo(text, err=as_json)

    progress = None if quiet else say
    common = dict(max_points=max_points, ds_max=ds_max, progress=progress, **given_options(dt=dt))
    branch = _first_branch(model, param, start, stop, from_branch, point, n_balls, sets,
                           period, settle, common)
    branches = [branch]
    for kind, wanted in (("PD", switch_pd), ("BP", switch_bp)):
        if wanted:
            switched = _switched_branch(branch, kind, stop, common, say)
            if switched is not None:
                branches.append(switched)
    _write_branches(branches, output, plot, as_json)


def _write_branches(branches: list, output: Path, plot: Path | None, as_json: bool) -> None:
    """Each branch to its file (a switched one beside ``output``, named by its switch),
    said in lines or JSON; the figure of them all."""
    from analysis.io import save_dataset

    paths = [output if i == 0 else
             output.with_name(f"{output.stem}-{SWITCH_SUFFIX[br.attrs['switched_at']]}"
                              f"{output.suffix}") for i, br in enumerate(branches)]
    for br, path in zip(branches, paths, strict=True):
        save_dataset(br, path)
        if not as_json:
            _print_branch(br, path)
    if plot:
        from analysis.reports.plots import branch_figure

        write_figure(branch_figure(branches), plot, err=as_json)
    if as_json:
        from analysis.provenance import provenance
        from analysis.stability.continuation import branch_summary

        echo_json({
            "branches": [{"file": str(path), **branch_summary(br),
                          "provenance": provenance(path)}
                         for br, path in zip(branches, paths, strict=True)],
            "plot": str(plot) if plot else None}, indent=2)


def _first_branch(model, param, start, stop, from_branch, point, n_balls, sets, period,
                  settle, common: dict):
    """The branch from MODEL --param --from, or from a point of --from-branch."""
    from analysis.stability import continuation as cont

    if from_branch is not None:
        given = [name for name, value in (("MODEL", model), ("--param", param),
                                          ("--from", start), ("--n-balls", n_balls),
                                          ("--set", sets), ("--period", period),
                                          ("--settle", settle))
                 if value not in (None, [])]
        if given:
            raise InputError(f"from-branch: the branch file sets the model, parameters and "
                             f"period; drop {', '.join(given)}")
        return cont.continue_from_branch(from_branch, point, stop=stop, **common)
    missing = [name for name, value in (("MODEL", model), ("--param", param),
                                        ("--from", start)) if value is None]
    if missing:
        raise InputError(f"continue: give {', '.join(missing)} (or --from-branch BRANCH.nc)")
    return cont.continue_orbits(model, parse_n_balls(n_balls), param=param, start=start,
                                stop=stop, period=period, **given_options(settle=settle), **common,
                                **parse_sets(sets))


def _switched_branch(branch, kind: str, stop: float, common: dict,
                     say: Callable[[str], None]):
    """The branch born at the first ``kind`` (PD or BP) point, or None (said why)."""
    from analysis.stability.continuation import ContinuationOptions, switch_and_continue

    steps = {name: common[name] for name in ("max_points", "ds_max")}
    switched = switch_and_continue(branch, kind, stop=stop,
                                   options=ContinuationOptions(**steps),
                                   dt=common.get("dt"), progress=common["progress"])
    if not switched.ok:
        say(switched.message)
    return switched.branch


def _print_branch(branch, path: Path) -> None:
    from analysis.stability.continuation.dataset import special_point_lines, special_point_notes

    lines = special_point_lines(branch)
    typer.echo(f"wrote {path}: {branch.sizes['point']} orbits ({branch.attrs['branch']}), "
               f"{branch.attrs['status']}; special points: {len(lines) or 'none'}")
    for line, note in zip(lines, special_point_notes(branch), strict=True):
        typer.echo(f"  {line}")
        if note:
            typer.echo(f"      {note}")
