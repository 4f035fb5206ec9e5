"""`bearingdyn hb`: periodic responses by harmonic balance, Hill's stability, continuation."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from analysis.cli.common import (
    JsonOption,
    ModelArgument,
    NBallsOption,
    PeriodOption,
    SetOption,
    app,
    figure_output,
    given_options,
    netcdf_output,
    parse_n_balls,
    parse_sets,
    reports_errors,
    write_figure,
)
from analysis.errors import InputError


@app.command()
@reports_errors
def hb(
    model: ModelArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the "
                                         "response(s).", callback=netcdf_output)],
    harmonics: Annotated[int, typer.Option(
        "--harmonics", help="Harmonics H of the base frequency 2π/T (>= 1).")] = 10,
    period: PeriodOption = None,
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    param: Annotated[str | None, typer.Option(
        help="Runtime parameter to continue in (with --from and --to).")] = None,
    start: Annotated[float | None, typer.Option(
        "--from", help="Start value (parameter unit).")] = None,
    stop: Annotated[float | None, typer.Option(
        "--to", help="End value (parameter unit).")] = None,
    samples: Annotated[int | None, typer.Option(
        help="AFT time samples per period (>= 2H + 1; default the fast size of "
             "max(4H + 1, 64)).")] = None,
    max_points: Annotated[int, typer.Option(help="Points per branch.")] = 200,
    ds_max: Annotated[float, typer.Option(help="Largest scaled arclength step.")] = 0.05,
    dt: Annotated[float | None, typer.Option(
        help="Largest RK4 step of the simulation that gives the first guess, s (default: "
             "the spec's).")] = None,
    settle: Annotated[float | None, typer.Option(
        help="Simulated time before the first guess, s (default: the model's own, as "
             "floquet).")] = None,
    plot: Annotated[Path | None, typer.Option(
        help="Figure: the amplitude of the first state against the parameter, stable "
             "solid, unstable dashed, special points marked.", callback=figure_output)] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
    as_json: JsonOption = False,
):
    """Periodic response by harmonic balance (AFT, exact Jacobian by CasADi AD) with Hill's
    stability; with --param, --from and --to its continuation (LP, PD, NS, BP points)."""
    from analysis.frequency import check_forced, check_harmonics
    from analysis.frequency.solve import prepare
    from analysis.model import as_system

    values = parse_sets(sets)
    continued = [name for name, value in (("--param", param), ("--from", start),
                                          ("--to", stop)) if value is not None]
    if continued and len(continued) < 3:
        missing = [n for n in ("--param", "--from", "--to") if n not in continued]
        raise InputError(f"{continued[0]}: continuation needs --param, --from and --to; "
                         f"give {', '.join(missing)}")
    system = as_system(model, parse_n_balls(n_balls), **values)
    check_harmonics(harmonics, system.n_state, "--harmonics")
    if param is not None:
        if param not in system.model.parameter_names:
            raise InputError(f"--param: '{param}' is not a parameter of "
                             f"'{system.model.name}'; choose one of "
                             f"{', '.join(system.model.parameter_names)}")
        system.model.parameters({param: start})
        system.model.parameters({param: stop})
        if start == stop:
            raise InputError("--to: must differ from --from")
        system = system.replace(**{param: start})
    check_forced(system)
    prepare(system, period)  # the period exists and lasts a finite time here
    from analysis.frequency.harmonic import fast_samples

    fast_samples(harmonics, samples)

    def say(text: str) -> None:
        if not quiet:
            typer.echo(text, err=True)

    options = given_options(dt=dt, settle=settle, samples=samples)
    if param is None:
        from analysis.frequency import harmonic_balance
        from analysis.frequency.solve import response_dataset

        response = harmonic_balance(system, None, period, harmonics, **options)
        if not response.converged:
            raise InputError(f"hb: no periodic response found ({response.message})")
        data = response_dataset(response)
    else:
        from analysis.frequency import continue_harmonic

        data = continue_harmonic(system, None, param=param, start=start, stop=stop,
                                 period=period, harmonics=harmonics, max_points=max_points,
                                 ds_max=ds_max, progress=say, **options)
    from analysis.io import save_dataset

    save_dataset(data, output)
    if not as_json:
        _print(data, output)
    if plot:
        write_figure(response_figure(data), plot, err=as_json)
    if as_json:
        from analysis.provenance import provenance

        typer.echo(json.dumps({"points": points_json(data), "file": str(output),
                               "provenance": provenance(output)}, indent=2))


def points_json(data) -> list[dict]:
    """One entry per point: the parameter (its unit, when continued), ``amplitude`` per
    state ((max − min)/2, its unit), ``stable``, ``special`` and ``residual``."""
    from analysis.provenance import plain

    param = data.attrs.get("param", "")
    out = []
    for j in range(data.sizes["point"]):
        point = {param: float(data[param].values[j])} if param else {}
        point.update(
            amplitude={str(s): float(a) for s, a in zip(data.state.values,
                                                          data.amplitude.values[j],
                                                          strict=True)},
            stable=bool(data.stable.values[j]),
            special=str(data.special.values[j]) if str(data.special.values[j]) in
            ("LP", "PD", "NS") else "",
            residual=plain(float(data.residual.values[j]), finite=True))
        out.append(point)
    return out


def _print(data, output: Path) -> None:
    param = data.attrs.get("param", "")
    n = data.sizes["point"]
    head = f"wrote {output}: "
    if not param:
        amp = ", ".join(f"{s} {float(a):.6g} {u}" for s, a, u in zip(
            data.state.values, data.amplitude.values[0], data.state_units.values,
            strict=True))
        mult = data.multiplier_abs.values[0]
        typer.echo(head + f"H = {data.attrs['harmonics']}, residual "
                   f"{float(data.residual.values[0]):.2e}, "
                   f"{'stable' if data.stable.values[0] else 'unstable'} (largest |μ| = "
                   f"{float(np.max(mult)):.6g}); amplitude {amp}")
        return
    specials = [(str(k), float(v)) for k, v in zip(data.special.values, data[param].values,
                                                   strict=True) if k]
    unit = data[param].attrs.get("units", "")
    typer.echo(head + f"{n} responses (H = {data.attrs['harmonics']}), "
               f"{data.attrs['status']}; special points: {len(specials) or 'none'}")
    for kind, value in specials:
        typer.echo(f"  {kind}  {param} = {value:.6g} {unit}".rstrip())


def response_figure(data):
    """The amplitude of the first state against the parameter (one point without one):
    stable solid, unstable dashed, special points marked."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 5), layout="constrained")
    ax = fig.add_subplot()
    param = data.attrs.get("param", "")
    state = str(data.state.values[0])
    unit = str(data.state_units.values[0])
    amp = data.amplitude.values[:, 0]
    lam = data[param].values if param else np.zeros(len(amp))
    stable = data.stable.values
    cuts = np.nonzero(np.diff(stable))[0] + 1
    for run in np.split(np.arange(len(lam)), cuts):
        run = np.append(run, run[-1] + 1) if run[-1] + 1 < len(lam) else run
        ax.plot(lam[run], amp[run], "-" if stable[run[0]] else "--", color="C0", lw=1.4,
                marker="o" if len(lam) == 1 else None)
    for j, kind in enumerate(data.special.values):
        if kind:
            ax.plot(lam[j], amp[j], "o", color="k", ms=5)
            ax.annotate(str(kind), (lam[j], amp[j]), xytext=(4, 4),
                        textcoords="offset points", fontsize=8)
    ax.plot([], [], "k-", label="stable (Hill)")
    ax.plot([], [], "k--", label="unstable (Hill)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    if param:
        ax.set_xlabel(f"{param} ({data[param].attrs.get('units', '')})")
    ax.set_ylabel(f"amplitude of {state}, (max - min)/2 ({unit})")
    ax.set_title(f"{data.attrs['model']}: harmonic balance, period {data.attrs['period']}, "
                 f"H = {data.attrs['harmonics']}", fontsize=9)
    return fig
