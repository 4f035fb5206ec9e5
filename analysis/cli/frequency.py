"""`bearingdyn hb`: periodic responses by harmonic balance, Hill's stability, continuation."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DsMaxOption,
    DtOption,
    FromOption,
    JsonOption,
    MaxPointsOption,
    ModelArgument,
    NBallsOption,
    ParamOption,
    PeriodOption,
    QuietOption,
    SetOption,
    SettleOption,
    ToOption,
    app,
    continued_systems,
    echo_json,
    figure_output,
    given_options,
    netcdf_output,
    parse_n_balls,
    parse_sets,
    progress_lines,
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
    param: ParamOption = None,
    start: FromOption = None,
    stop: ToOption = None,
    samples: Annotated[int | None, typer.Option(
        help="AFT time samples per period (>= 2H + 1; default the fast size of "
             "max(4H + 1, 64)).")] = None,
    max_points: MaxPointsOption = 200,
    ds_max: DsMaxOption = 0.05,
    dt: DtOption = None,
    settle: SettleOption = None,
    plot: Annotated[Path | None, typer.Option(
        help="Figure: the amplitude of the first state against the parameter, stable "
             "solid, unstable dashed, special points marked.", callback=figure_output)] = None,
    quiet: QuietOption = False,
    as_json: JsonOption = False,
):
    """Periodic response by harmonic balance (AFT, exact Jacobian by CasADi AD) with Hill's
    stability; with --param, --from and --to its continuation (LP, PD, NS, BP points).
    Prefer it for a periodic response (one forcing period); for a quasi-periodic one (shaft
    and cage frequencies) use `torus`, whose default invariant circle is accurate on
    contact. Prints its error estimate: the change at 2H and at twice the samples. Says
    its expected cost first (a timed Newton iteration x iterations x points)."""
    from analysis.cli.plans import run_plan
    from analysis.frequency.methods import PERIODIC, Request, plan_branch
    from analysis.model import as_system

    system, end = continued_systems(as_system(model, parse_n_balls(n_balls),
                                              **parse_sets(sets)), param, start, stop)
    request = Request(harmonics, period=period, param=param, start=start, stop=stop,
                      max_points=max_points, ds_max=ds_max,
                      options=given_options(dt=dt, settle=settle, samples=samples),
                      progress=progress_lines(quiet), figure=0.0 if plot else None)
    plan = plan_branch(PERIODIC["hb"], system, request, end, output, kind="hb")
    data, _ = run_plan(plan, quiet=quiet, lines=True)
    _finish(data, output, as_json, lambda: _print(data, output),
            plot and (plot, lambda: response_figure(data)),
            json_attrs(data, HB_JSON))


HB_JSON = ("error_harmonics", "error_harmonics_at", "error_aliasing", "error_bound",
           "error_at", "error_notes")
"""The HB attrs ``hb --json`` carries beside the points (NaN as null, ``null_note`` why)."""


def json_attrs(data, keys) -> dict:
    from analysis.frequency.accuracy import json_attrs as attrs

    return attrs(data, keys)


def _finish(data, output: Path, as_json: bool, say, figure, extra: dict | None = None,
            also: dict | None = None) -> None:
    """After ``data`` was written to ``output`` (``run_plan``): write each Dataset of
    ``also`` to its path; say so (``say()``) or print the JSON of its points (with
    ``extra``); ``figure``: (path, figure maker) or None."""
    from analysis.io import save_dataset

    for path, dataset in (also or {}).items():
        save_dataset(dataset, path)
    if not as_json:
        say()
    if figure:
        write_figure(figure[1](), figure[0], err=as_json)
    if as_json:
        from analysis.provenance import provenance

        out = {"points": points_json(data), "file": str(output),
               "provenance": provenance(output)}
        echo_json(out | (extra or {}), indent=2)


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
            stable=bool(data.stable.values[j] == 1),  # a torus: -1 not computed
            special=str(data.special.values[j]) if str(data.special.values[j]) in
            ("LP", "PD", "NS") else "",
            residual=plain(float(data.residual.values[j]), finite=True))
        out.append(point)
    return out


def _print(data, output: Path) -> None:
    import numpy as np

    from analysis.frequency.accuracy import error_words

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
        typer.echo(error_words(data))
        return
    specials = [(str(k), float(v)) for k, v in zip(data.special.values, data[param].values,
                                                   strict=True) if k]
    unit = data[param].attrs.get("units", "")
    typer.echo(head + f"{n} responses (H = {data.attrs['harmonics']}), "
               f"{data.attrs['status']}; special points: {len(specials) or 'none'}")
    for kind, value in specials:
        typer.echo(f"  {kind}  {param} = {value:.6g} {unit}".rstrip())
    typer.echo(error_words(data))


def response_figure(data):
    """The amplitude of the first state against the parameter (one point without one):
    stable solid, unstable dashed, special points marked; the PNG carries the result's
    provenance (``canvas.finish``)."""
    import numpy as np

    from analysis.reports import canvas

    fig, ax = canvas.subplots(figsize=(8, 5), layout="constrained")
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
    from analysis.reports.plots import scaled_axis  # µm for m, as every figure (issue 32)

    shown = scaled_axis(ax.yaxis, unit, float(np.nanmax(np.abs(amp), initial=0.0)))
    ax.set_ylabel(f"amplitude of {state}, (max - min)/2 ({shown})")
    from analysis.frequency.accuracy import error_words

    ax.set_title(f"{data.attrs['model']}: harmonic balance, period {data.attrs['period']}, "
                 f"H = {data.attrs['harmonics']}\n{error_words(data)}", fontsize=9)
    return canvas.finish(fig, data)


FrequenciesOption = Annotated[str, typer.Option(
    "--frequencies", help="Two base frequencies F1,F2: shaft, vc, vc[name] or param:NAME.")]
TorusHarmonicsOption = Annotated[str | None, typer.Option(
    "--harmonics", help="Harmonics H1,H2 of F1 and F2 (each >= 1; selects --method hb; "
                        "default 8,4).")]
TorusMethodOption = Annotated[str | None, typer.Option(
    "--method", help="shooting: the invariant circle of the F1-period map, within 1e-3 of "
                     "the amplitude on contact models (prefer it there; with --param, "
                     "continued without λ1); hb: 2-D harmonic balance, fast and fine for "
                     "smooth forces, but 20-38 % of the amplitude off on every shipped "
                     "contact model although its residual reads 1e-10. Default: shooting "
                     "when F1 is shaft or param:NAME and F2 a vc and --harmonics is not "
                     "given, else hb.")]
PointsOption = Annotated[int | None, typer.Option(
    "--points", help="Circle points N of --method shooting (>= 8; default 65).")]
LyapunovDurationOption = Annotated[float, typer.Option(
    help="Averaging time of λ1 from the torus, s (0: no λ1).")]
StabilityEveryOption = Annotated[int, typer.Option(
    help="On a branch, λ1 at every k-th torus and the last (>= 1).")]
TorusRunOption = Annotated[Path | None, typer.Option(
    help="Also write a run from the (last) torus, readable by spectrum, poincare and plot: "
         "of a circle, each revolution integrated from its section point (within 1e-3 of "
         "the amplitude at every time, measured 2.3e-4 over 20 s at N = 65); of an HB "
         "torus, its series.", callback=netcdf_output)]
TorusDurationOption = Annotated[float, typer.Option(
    help="Length of the --run series and of the figure's time run, s.")]
TorusPlotOption = Annotated[Path | None, typer.Option(
    help="Figure: the torus's shaft section u(0, θ2) against the Poincaré section of a time "
         "run.", callback=figure_output)]


@app.command()
@reports_errors
def torus(
    model: ModelArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the "
                                         "torus (or branch of tori).", callback=netcdf_output)],
    frequencies: FrequenciesOption = "shaft,vc",
    harmonics: TorusHarmonicsOption = None,
    method: TorusMethodOption = None,
    points: PointsOption = None,
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    param: ParamOption = None,
    start: FromOption = None,
    stop: ToOption = None,
    max_points: MaxPointsOption = 100,
    ds_max: DsMaxOption = 0.05,
    lyapunov_duration: LyapunovDurationOption = 2.0,
    stability_every: StabilityEveryOption = 1,
    dt: DtOption = None,
    settle: SettleOption = None,
    run: TorusRunOption = None,
    duration: TorusDurationOption = 2.0,
    plot: TorusPlotOption = None,
    quiet: QuietOption = False,
    as_json: JsonOption = False,
):
    """Quasi-periodic response on a 2-torus of two base frequencies and its λ1; with
    --param, --from and --to its continuation. Default for shaft,vc: the invariant circle
    of the F1-period map (RK4, AD Jacobian; within 1e-3 of the amplitude on contact at
    every time of its --run, not only at the sections; its tail and change at 2N printed).
    --method hb (or --harmonics): 2-D harmonic balance, for smooth forces only: on contact
    models 20-38 % off whatever its residual; prints its change at 2H and its aliasing.
    Says its expected cost first."""
    from analysis.cli.plans import run_plan
    from analysis.frequency import methods as m
    from analysis.frequency.circle_run import circle_run
    from analysis.model import as_system

    chosen = m.method_of(m.TORUS, method or m.default_torus_method(frequencies, harmonics),
                         "method")
    resolution = _resolution(chosen, harmonics=harmonics, points=points)
    system, end = continued_systems(as_system(model, parse_n_balls(n_balls),
                                              **parse_sets(sets)), param, start, stop)
    _check_run(system, run, duration, dt)
    request = m.Request(resolution, frequencies=frequencies, param=param, start=start,
                        stop=stop, max_points=max_points, ds_max=ds_max,
                        lyapunov_duration=lyapunov_duration, stability_every=stability_every,
                        options=given_options(dt=dt, settle=settle),
                        progress=progress_lines(quiet),
                        figure=max(duration, 2.0) if plot else None)
    data, _ = run_plan(m.plan_branch(chosen, system, request, end, output, kind="torus"),
                       quiet=quiet, lines=True)
    also = {}
    if run:  # an invariant circle's run is integrated between its sections
        also[run] = circle_run(data, duration, dt)
    _finish(data, output, as_json, lambda: _print_torus(data, output, run),
            plot and (plot, lambda: torus_figure(data, duration, dt)),
            _torus_extra(data), also)


TORUS_JSON = ("stop_report", "error_harmonics", "error_harmonics_at", "error_aliasing",
              "error_at", "error_notes", "amplitude_error", "circle_change", "between_error",
              "run_step_error")
"""The torus attrs its --json carries beside the points (NaN as null, with its reason in
``error_notes`` where one was stored)."""


def _torus_extra(data) -> dict | None:
    return json_attrs(data, TORUS_JSON) or None


def _lambda_words(data) -> str:
    """'lambda1 λ ± w 1/s', or why it is not there (never 'nan')."""
    lam, ci = float(data.lambda1.values[0]), float(data.lambda1_ci95.values[0])
    if not math.isfinite(lam):
        return "lambda1 not computed (--lyapunov-duration 0, or its run left the torus)"
    return f"lambda1 {lam:.4g} ± {_number(ci, '.2g')} 1/s"


def _number(value, digits: str = ".1e") -> str:
    """``value`` formatted, or 'not computed' for a missing or NaN one (never 'nan')."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return "not computed"
    return format(number, digits) if math.isfinite(number) else "not computed"


def _check_run(system, run: Path | None, duration: float, dt: float | None) -> None:
    """--duration, and with --run the run's samples at --dt, judged before any torus is
    solved."""
    from analysis.integrate.checks import check_seconds

    check_seconds("--duration", duration)
    if run:
        from analysis.frequency.torus.dataset import check_torus_run

        check_torus_run(system, duration, dt)


def _resolution(chosen, **given):
    """The resolution given for ``chosen``, else its default, which the command then holds
    as that option's value (so a refusal of it, field ``points``, names ``--points`` as
    one of a given value: ``common.as_option``); one given for another method is refused
    in one line."""
    from analysis.cli.common import click
    from analysis.frequency.methods import TORUS

    for name, value in given.items():
        if value is not None and name != chosen.resolution:
            owner = next(m.name for m in TORUS.values() if m.resolution == name)
            raise InputError(f"--{name}: applies to --method {owner} only; {chosen.resolved}")
    value = given[chosen.resolution]
    if value is None:
        value = chosen.default
        context = click.globals.get_current_context(silent=True)
        if context is not None:
            context.params[chosen.resolution] = value
    return value


HB_CAUTION = ("note: the residual is not the error: on contact models 2-D harmonic balance "
              "is 20-38 % of the amplitude off (docs/frequency.md); --method shooting is "
              "within 1e-3")
"""The line under every torus HB result."""


def _print_torus(data, output: Path, run: Path | None) -> None:
    from analysis.frequency.accuracy import error_words

    param = data.attrs.get("param", "")
    head = (f"wrote {output}: torus {data.attrs['frequencies']}, H = "
            f"{data.attrs['harmonics']}, ")
    if data.attrs.get("solver") == "shooting" and param:
        typer.echo(f"wrote {output}: torus {data.attrs['frequencies']} by the invariant "
                   f"circle of N = {data.attrs['points']} points, {data.sizes['point']} "
                   "circles (lambda1 not computed)")
        typer.echo(str(data.attrs["stop_report"]))
    elif data.attrs.get("solver") == "shooting":
        amp = ", ".join(f"{s} {float(a):.6g} {u}" for s, a, u in zip(
            data.state.values, data.amplitude.values[0], data.state_units.values,
            strict=True))
        typer.echo(f"wrote {output}: torus {data.attrs['frequencies']} by the invariant "
                   f"circle of N = {data.attrs['points']} points, residual "
                   f"{float(data.residual.values[0]):.2e}, circle tail "
                   f"{float(data.border.values[0]):.1e}, change at N = "
                   f"{data.attrs['circle_change_points']}: "
                   f"{_number(data.attrs['circle_change'])}; {_lambda_words(data)}; "
                   f"amplitude {amp}")
        typer.echo(f"amplitude: (max - min)/2 over revolutions integrated from "
                   f"{4 * int(data.attrs['points'])} cage phases of the circle, every RK4 "
                   f"step; its change from half as many phases "
                   f"{_number(data.attrs.get('amplitude_error'))}")
        typer.echo(f"between the sections: --run integrates each revolution from its "
                   f"circle point (at half the RK4 step it moves "
                   f"{_number(data.attrs.get('run_step_error'))} of the "
                   f"amplitude; at the sections it is the circle, change above); the stored "
                   f"2-D series is {_number(data.attrs.get('between_error'))} from that run")
    elif not param:
        amp = ", ".join(f"{s} {float(a):.6g} {u}" for s, a, u in zip(
            data.state.values, data.amplitude.values[0], data.state_units.values,
            strict=True))
        typer.echo(head + f"residual {float(data.residual.values[0]):.2e} (finer grid "
                   f"{_number(data.residual_fine.values[0], '.2e')}), "
                   f"{_lambda_words(data)}; amplitude {amp}")
        typer.echo(error_words(data))
        typer.echo(HB_CAUTION)
    else:
        typer.echo(head + f"{data.sizes['point']} tori")
        typer.echo(str(data.attrs["stop_report"]))
        typer.echo(error_words(data))
        typer.echo(HB_CAUTION)
    if run:
        typer.echo(f"wrote {run}")


def torus_figure(data, duration: float, dt: float | None = None):
    """The shaft section of the (last) torus, u(0, θ2) for θ2 in [0, 2π), against the
    Poincaré section (shaft) of a time run of the same system from a state on the torus,
    in the first two states; the PNG carries the result's provenance (``canvas.finish``)."""
    import numpy as np

    from analysis.frequency import torus_of
    from analysis.frequency.accuracy import error_words
    from analysis.integrate.simulate import simulate
    from analysis.reports import canvas
    from analysis.reports.plots import scale_of
    from analysis.signal.poincare import poincare_section

    ts, coeffs = torus_of(data, -1)
    phi = np.linspace(0, 2 * np.pi, 721)
    curve = ts.basis.evaluate(coeffs, np.zeros_like(phi), phi, ts.n)
    z0 = ts.at_times(coeffs, np.array([0.0]))[0]
    settle = float(ts.system.model.simulation_defaults["transient"])
    ds = simulate(ts.system.replace(state=z0), duration=settle + max(duration, 2.0),
                  transient=settle, dt=dt)
    sec = poincare_section(ds, "shaft")
    a, b = ts.system.state_names[:2]
    fa, ua = scale_of(ds, a)
    fb, ub = scale_of(ds, b)
    param = data.attrs.get("param", "")
    if param:
        fig, (left, ax) = canvas.subplots(1, 2, figsize=(12, 5), layout="constrained")
        _branch_axes(left, data)
    else:
        fig, ax = canvas.subplots(figsize=(6.5, 5.5), layout="constrained")
    shooting = data.attrs.get("solver") == "shooting"
    label = (f"invariant circle u(0, θ2), N = {data.attrs['points']} (tail "
             f"{float(data.border.values[-1]):.1e}, change at 2N "
             f"{_number(data.attrs.get('circle_change'))})" if shooting else
             f"torus section u(0, θ2), H = {data.attrs['harmonics']} (2-D HB: 20-38 % off "
             f"on contact)\n{error_words(data)}")
    ax.plot(sec[a].values * fa, sec[b].values * fb, ".", ms=3, color="C1",
            label=f"Poincaré section of a time run ({len(sec[a])} revolutions)")
    ax.plot(curve[:, 0] * fa, curve[:, 1] * fb, "-", color="C0", lw=1.2,
            label=label)
    ax.set_xlabel(f"{a} ({ua})")
    ax.set_ylabel(f"{b} ({ub})")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    where = ""
    if param:
        where = f", {param} = {float(data[param].values[-1]):.6g}"
    ax.set_title(f"{data.attrs['model']}: torus {data.attrs['frequencies']} at the shaft "
                 f"section (t = k/X){where}", fontsize=9)
    return canvas.finish(fig, data)


def _branch_axes(ax, data) -> None:
    """Amplitude of the first state along a branch of tori: λ1 stable solid, not stable
    dashed, not computed dotted; LP points marked."""
    from analysis.reports.plots import unit_scale

    param = data.attrs["param"]
    lam = data[param].values
    state = str(data.state.values[0])
    factor, unit = unit_scale(str(data.state_units.values[0]))
    amp = data.amplitude.values[:, 0] * factor
    known = data.stable.values >= 0
    ax.plot(lam, amp, ":", color="C0", lw=1.0, label="torus (λ1 not computed)")
    for value, style, label in ((1, "o", "λ1 < 0 beyond its 95 % half-width: attracting"),
                                (0, "x", "not shown attracting (λ1 + half-width ≥ 0, "
                                         "or the trajectory left the torus)")):
        sel = known & (data.stable.values == value)
        if sel.any():
            ax.plot(lam[sel], amp[sel], style, color="C0" if value else "C3", ms=4,
                    label=label)
    for j, kind in enumerate(data.special.values):
        if kind == "LP":
            ax.plot(lam[j], amp[j], "s", color="k", ms=4)
            ax.annotate("LP", (lam[j], amp[j]), xytext=(3, 3), textcoords="offset points",
                        fontsize=7)
    ax.set_xlabel(f"{param} ({data[param].attrs.get('units', '')})")
    ax.set_ylabel(f"amplitude of {state}, (max - min)/2 ({unit})")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(f"branch of tori, H = {data.attrs['harmonics']}: "
                 f"{str(data.attrs['status'])[:60]}", fontsize=9)
