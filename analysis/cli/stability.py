"""Stability of one setting: `lyapunov`, `floquet` and `classify`."""

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
    SpeedOption,
    _given,
    _orbit_structure,
    _parameters,
    _save_figure,
    app,
    parse_n_balls,
    reports_errors,
)


@app.command()
@reports_errors
def lyapunov(
    model: ModelArgument,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    duration: Annotated[float, typer.Option(help="Averaging time after the transient, s.")] = 5.0,
    transient: Annotated[float | None, typer.Option(help="Dropped initial time, s.")] = None,
    dt: Annotated[float | None, typer.Option(help="RK4 step, s.")] = None,
    renorm_every: Annotated[int, typer.Option(help="RK4 steps between QR steps.")] = 100,
    as_json: JsonOption = False,
    output: Annotated[Path | None, typer.Option("-o", "--output",
                                                help="Figure of the running estimates.")] = None,
):
    """Lyapunov spectrum (one exponent per state variable, 1/s) from the tangent dynamics of
    the RK4 map."""
    from analysis.stability.lyapunov import lyapunov as run_lyapunov

    res = run_lyapunov(model, parse_n_balls(n_balls), duration=duration, transient=transient,
                       dt=dt, renorm_every=renorm_every, **_parameters(speed_rpm, sets))
    data = {"exponents": res.exponents.values.tolist(), "ci95": res.ci95.values.tolist(),
            "sum_of_exponents": res.attrs["sum_of_exponents"],
            "mean_divergence": res.attrs["mean_divergence"],
            **{k: int(v) for k, v in res.attrs.items() if str(k).startswith("n_balls")}}
    if as_json:
        typer.echo(json.dumps(data, indent=2))
    else:
        for k, (lam, ci) in enumerate(zip(data["exponents"], data["ci95"], strict=True), 1):
            typer.echo(f"λ{k} = {lam:12.5g} ± {ci:.2g} 1/s (95 %)")
        typer.echo(f"sum = {data['sum_of_exponents']:.6g} 1/s; mean divergence "
                   f"{data['mean_divergence']:.6g} 1/s")
    if output:
        from analysis.reports.plots import lyapunov_figure

        _save_figure(lyapunov_figure(res), output, err=as_json)


@app.command()
@reports_errors
def floquet(
    model: ModelArgument,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    segments: Annotated[int, typer.Option(help="Shooting segments (1: single).")] = 1,
    dt: Annotated[float | None, typer.Option(
        help="Largest RK4 step, s (default: the spec's).")] = None,
    settle: Annotated[float, typer.Option(help="Simulated time for the guess, s.")] = 0.5,
    as_json: JsonOption = False,
):
    """Periodic orbit by Newton shooting, its Floquet multipliers and stability."""
    from analysis.stability.periodic import shoot

    orbit = shoot(model, parse_n_balls(n_balls), period, segments=segments, settle=settle,
                  **_given(dt=dt), **_parameters(speed_rpm, sets))
    if as_json:
        typer.echo(json.dumps(orbit.as_dict(), indent=2))
        return
    typer.echo(f"{orbit.model}, {_orbit_structure(orbit)}, period {orbit.period} = "
               f"{orbit.period_s:.6g} s ({orbit.n_steps} RK4 steps): {orbit.message}")
    names = getattr(orbit, "state_names", ()) or ()
    typer.echo(f"z0 = {np.array2string(orbit.z0, precision=6)}"
               + (f" ({', '.join(names)})" if names else " (m, m/s)")
               + f" at t0 = {orbit.t0:g} s")
    for mu in orbit.multipliers:
        typer.echo(f"  μ = {mu.real:+.6f} {mu.imag:+.6f}i   |μ| = {abs(mu):.6f}")
    typer.echo(f"stability: {orbit.stability} (spectral radius {orbit.spectral_radius:.6f})")


@app.command()
@reports_errors
def classify(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    section: Annotated[str | None, typer.Option(
        help="shaft, cage, vc, cage[BEARING], vc[BEARING] or param:NAME (default: vc for a "
             "balanced bearing, else shaft).")] = None,
    as_json: JsonOption = False,
):
    """Periodic-n, quasi-periodic or chaotic (computes the largest Lyapunov exponent when
    the Poincaré points alone cannot tell)."""
    from analysis.io import load_dataset
    from analysis.stability.classify import classify as run_classify

    result = run_classify(load_dataset(run_file), section)
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=2))
    else:
        typer.echo(f"{result.nature}: {result.detail} ({result.n_points} points, "
                   f"{result.section} section)")
