"""Stability of one setting: `lyapunov`, `floquet` and `classify`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DtOption,
    JsonOption,
    ModelArgument,
    NBallsOption,
    PeriodOption,
    QuietOption,
    SetOption,
    SettleOption,
    SpeedOption,
    app,
    echo_json,
    figure_output,
    given_options,
    orbit_structure,
    parameter_values,
    parse_n_balls,
    reports_errors,
    write_figure,
)

RUNNING_ROWS = 200
"""Most rows of each running estimate in the JSON output (evenly thinned, the last kept)."""
PROGRESS_AFTER = 2.0
"""Seconds before ``classify`` shows the progress of its Lyapunov exponent (none sooner)."""


@app.command()
@reports_errors
def lyapunov(
    model: ModelArgument,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    duration: Annotated[float | None, typer.Option(
        help="Averaging time, s (default: ten times the spec's duration).")] = None,
    transient: Annotated[float | None, typer.Option(
        help="Time before the averaging starts, s (default: the spec's).")] = None,
    tangent_transient: Annotated[float | None, typer.Option(
        help="Renormalised time before the averaging whose logs are discarded, s (the last "
             "part of the transient; default: a tenth of the spec's transient).")] = None,
    dt: DtOption = None,
    renorm_every: Annotated[int, typer.Option(help="RK4 steps between QR steps.")] = 100,
    as_json: JsonOption = False,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Figure of the running estimates (the discarded tangent "
                               "transient shaded).", callback=figure_output)] = None,
):
    """Lyapunov spectrum (one exponent per state variable, 1/s) from the tangent dynamics of
    the RK4 map, with its running estimates."""
    from analysis.stability.lyapunov import lyapunov as run_lyapunov

    res = run_lyapunov(model, parse_n_balls(n_balls), renorm_every=renorm_every,
                       **given_options(duration=duration, transient=transient,
                                tangent_transient=tangent_transient, dt=dt),
                       **parameter_values(speed_rpm, sets))
    data = {"exponents": res.exponents.values.tolist(), "ci95": res.ci95.values.tolist(),
            "sum_of_exponents": res.attrs["sum_of_exponents"],
            "mean_divergence": res.attrs["mean_divergence"],
            **{k: float(res.attrs[k]) for k in ("dt", "transient", "tangent_transient",
                                                  "duration")},
            "averaging_start": float(res.t[0]) - float(res.t[1] - res.t[0]),
            "running": _running_json(res.running, "t"),
            "transient_running": _running_json(res.transient_running, "t_transient"),
            **{k: int(v) for k, v in res.attrs.items() if str(k).startswith("n_balls")}}
    if as_json:
        from analysis.provenance import provenance

        echo_json({**data, "provenance": provenance(res)}, indent=2)
    else:
        _echo_lyapunov(res, data)
    warning = unresolved_warning(data["exponents"][0], data["ci95"][0], data["duration"])
    if warning:
        typer.echo(warning, err=True)
    if output:
        write_figure(_lyapunov_figure(res), output, err=as_json)


def unresolved_warning(value: float, ci95: float, duration: float) -> str | None:
    """A warning line when λ1's 95 % interval (1/s) is wider than λ1 itself (its sign is
    not resolved), with the averaging time (s) that would narrow the interval to half the
    value (the interval shrinks as 1/sqrt(duration)); None when it is resolved."""
    if not ci95 > abs(value):
        return None
    import numpy as np

    if value == 0 or not np.isfinite(ci95):
        need = "a much longer run"
    else:
        need = f"about {duration * (2 * ci95 / abs(value)) ** 2:.3g} s of averaging"
    return (f"warning: λ1 = {value:.4g} ± {ci95:.2g} 1/s: the interval is wider than the "
            f"value, so its sign is not resolved by {duration:g} s of averaging; {need} "
            "(--duration) would narrow it to half the value")


def _running_json(running, dim: str) -> dict:
    """``{"t": [...], "exponents": [[λ1, λ2, …] per time]}`` of a running estimate (1/s
    over s), thinned evenly to at most ``RUNNING_ROWS`` rows (the last kept)."""
    import numpy as np

    size = running.sizes[dim]
    keep = np.unique(np.linspace(0, size - 1, min(size, RUNNING_ROWS)).round().astype(int)) \
        if size else np.array([], dtype=int)
    part = running.isel({dim: keep})
    return {"t": part[dim].values.tolist(), "exponents": part.values.tolist()}


def _echo_lyapunov(res, data: dict) -> None:
    """The exponents, the sum rule, the lengths and λ1's running estimate in words."""
    for k, (lam, ci) in enumerate(zip(data["exponents"], data["ci95"], strict=True), 1):
        typer.echo(f"λ{k} = {lam:12.5g} ± {ci:.2g} 1/s (95 %)")
    typer.echo(f"sum = {data['sum_of_exponents']:.6g} 1/s; mean divergence "
               f"{data['mean_divergence']:.6g} 1/s")
    typer.echo(f"averaged over {data['duration']:g} s from t = {data['averaging_start']:g} s "
               f"after a tangent transient of {data['tangent_transient']:g} s (discarded)")
    running = res.running.sel(index=1)
    marks = [running.isel(t=max(0, round(f * running.sizes["t"]) - 1))
             for f in (0.1, 0.25, 0.5, 0.75, 1.0)]
    typer.echo("running λ1: " + ", ".join(f"{float(m):.4g} (t = {float(m.t):.4g} s)"
                                           for m in marks))


def _lyapunov_figure(res):
    """``lyapunov_figure``: it draws the discarded tangent transient too (dashed, grey
    span) at the averaged estimates' vertical scale."""
    from analysis.reports.plots import lyapunov_figure

    return lyapunov_figure(res)


@app.command()
@reports_errors
def floquet(
    model: ModelArgument,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    segments: Annotated[int, typer.Option(help="Shooting segments (1: single).")] = 1,
    dt: DtOption = None,
    settle: SettleOption = None,
    as_json: JsonOption = False,
):
    """Periodic orbit by Newton shooting, its Floquet multipliers and stability."""
    from analysis.stability.periodic import shoot

    orbit = shoot(model, parse_n_balls(n_balls), period, segments=segments,
                  **given_options(dt=dt, settle=settle), **parameter_values(speed_rpm, sets))
    if as_json:
        from analysis.provenance import provenance

        echo_json({**orbit.as_dict(), "provenance": provenance(orbit.system)}, indent=2)
        return
    typer.echo(f"{orbit.model}, {orbit_structure(orbit)}, period {orbit.period} = "
               f"{orbit.period_s:.6g} s ({orbit.n_steps} RK4 steps): {orbit.message}")
    import numpy as np

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
    quiet: QuietOption = False,
):
    """Periodic-n, quasi-periodic or chaotic (computes the largest Lyapunov exponent when
    the Poincaré points alone cannot tell, with its progress on stderr)."""
    from analysis.provenance import load_dataset
    from analysis.reports.progress import ProgressReporter
    from analysis.stability.classify import classify as run_classify

    result = run_classify(load_dataset(run_file), section, progress=ProgressReporter(
        "classify: largest Lyapunov exponent", quiet, unit="blocks", after=PROGRESS_AFTER))
    if as_json:
        from analysis.provenance import provenance

        echo_json({**result.as_dict(), "provenance": provenance(run_file)}, indent=2)
    else:
        typer.echo(f"{result.label}: {result.detail} ({result.n_points} points, "
                   f"{result.section} section)")
