"""`bearingdyn campbell` and `bearingdyn unbalance`: the linear analyses of a spec's
finite-element rotor (``analysis.linear``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, echo_json, figure_output, reports_errors, write_figure

ModelArgument = Annotated[str, typer.Argument(
    help="A spec with a [shaft] (its path, or a shipped or user spec's name).")]
SpeedsOption = Annotated[str, typer.Option(
    "--speeds", help="Shaft speeds, rpm: LO:HI:N (N speeds from LO to HI) or a comma list.")]


@app.command()
@reports_errors
def campbell(
    model: ModelArgument,
    speeds: SpeedsOption,
    modes: Annotated[int, typer.Option(
        "--modes", help="Modes per speed (the lowest damped frequencies).")] = 6,
    critical: Annotated[bool, typer.Option(
        "--critical-speeds", help="List the critical speeds in --json too, and fail unless "
                                  "the speed range passes at least one.")] = False,
    as_json: Annotated[bool, typer.Option(
        "--json", help='Print {"speed_rpm", "frequency_hz", "log_dec", "whirl"} (per mode, '
                       "ascending frequency) as JSON.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.",
                                                callback=figure_output)] = None,
):
    """Campbell diagram of a finite-element rotor: the damped natural frequencies, log
    decrements and whirl (forward, backward, mixed) of its lateral modes over speed, and the
    critical speeds where a mode crosses the 1X line. Without -o or --json, prints the modes
    at the first and last speed and the critical speeds."""
    from analysis.cli.stiffness import parse_speeds
    from analysis.linear import campbell as compute
    from analysis.linear.campbell import check_critical
    from analysis.linear.rotor import load_rotor

    rpm = parse_speeds(speeds)
    rotor = load_rotor(model, rpm)
    result = compute(rotor.matrices, rpm, modes, rotor.lines)
    if critical:
        check_critical(result)
    if output:
        from analysis.reports.campbell_plots import campbell_figure

        write_figure(campbell_figure(result, f"Campbell diagram: {rotor.name}", rotor.source()),
                     output, err=as_json)
    if as_json:
        echo_json(result.to_json(critical))
    else:
        _print_campbell(result)


def _print_campbell(result) -> None:
    speeds = result.speed_rpm
    typer.echo(f"{result.frequency_hz.shape[0]} modes at {speeds.size} speeds, "
               f"{speeds[0]:g} to {speeds[-1]:g} rpm")
    typer.echo(f"{'mode':>4} {'f (Hz) first':>13} {'f (Hz) last':>12} {'log dec last':>13} "
               f"{'whirl last':>10}")
    for i, row in enumerate(result.frequency_hz):
        typer.echo(f"{i:4d} {row[0]:13.3f} {row[-1]:12.3f} {result.log_dec[i, -1]:13.4g} "
                   f"{result.whirl[i, -1] or '-':>10}")
    for c in result.critical:
        typer.echo(f"critical speed {c.speed_rpm:.1f} rpm: mode {c.mode} ({c.whirl}) at "
                   f"{c.frequency_hz:.3f} Hz on {c.line}")
    if not result.critical:
        typer.echo("no critical speed in this speed range")


@app.command()
@reports_errors
def unbalance(
    model: ModelArgument,
    node: Annotated[int, typer.Option("--node", help="Node whose x response is reported.")],
    speeds: SpeedsOption,
    unbalances: Annotated[list[str] | None, typer.Option(
        "--unbalance", help="NODE:KG_M[:PHASE_DEG], repeatable (default: the spec's "
                            "[[shaft.unbalances]]).")] = None,
    as_json: Annotated[bool, typer.Option(
        "--json", help='Print {"speed_rpm", "amplitude_m", "phase_deg"} as JSON.')] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file (Bode).",
                                                callback=figure_output)] = None,
):
    """1X unbalance response of a finite-element rotor at a node: x(t) = |X| cos(Ωt + phase)
    from the linear model, as ROSS's run_unbalance_response. Without -o or --json, prints
    the largest amplitude and where it occurs."""
    from analysis.cli.stiffness import parse_speeds
    from analysis.linear import campbell as modes_of
    from analysis.linear import unbalance_response
    from analysis.linear.rotor import load_rotor, parse_unbalance

    rpm = parse_speeds(speeds)
    rotor = load_rotor(model, rpm)
    given = [parse_unbalance(u, rotor.matrices.n_nodes) for u in unbalances or []]
    result = unbalance_response(rotor.matrices, node, rpm, given or list(rotor.shaft.unbalances))
    if output:
        from analysis.reports.campbell_plots import bode_figure

        critical = tuple(c.speed_rpm for c in modes_of(rotor.matrices, result.speed_rpm, 6,
                                                       rotor.lines).critical)
        write_figure(bode_figure(result, f"1X unbalance response at node {node}: "
                                 f"{rotor.name}", rotor.source(), critical), output,
                     err=as_json)
    if as_json:
        echo_json(result.to_json())
    else:
        k = int(result.amplitude_m.argmax())
        typer.echo(f"x at node {node}, {result.speed_rpm.size} speeds: largest amplitude "
                   f"{result.amplitude_m[k]:.4e} m at {result.speed_rpm[k]:.1f} rpm "
                   f"(phase {result.phase_deg[k]:.1f} deg)")
