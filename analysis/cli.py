"""The ``bearingdyn`` command."""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from analysis.errors import BearingdynError, InputError

app = typer.Typer(no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                  help="Rotor-ball-bearing models from equation specs: generate, simulate, "
                       "analyse. SI units; speeds in rpm.")
_state = {"debug": False}


@app.callback()
def _main(debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks.")] = False):
    _state["debug"] = debug


def reports_errors(command):
    """Turn user errors into one line on stderr and exit code 2 (tracebacks with --debug)."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from modelgen.errors import SpecError

        try:
            return command(*args, **kwargs)
        except (BearingdynError, SpecError) as exc:
            if _state["debug"]:
                raise
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None

    return wrapper


def parse_sets(items: list[str] | None) -> dict[str, float]:
    """``["damping=100", "radial_load=20"]`` -> {"damping": 100.0, "radial_load": 20.0}."""
    values: dict[str, float] = {}
    for item in items or []:
        name, sep, text = item.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--set: expected name=value, got {item!r}")
        try:
            values[name.strip()] = float(text)
        except ValueError:
            raise InputError(f"--set {name.strip()}: value must be a number, "
                             f"got {text!r}") from None
    return values


SetOption = Annotated[list[str] | None, typer.Option(
    "--set", help="Parameter override name=value (SI units), repeatable.")]


@app.command()
@reports_errors
def generate(
    specs: Annotated[list[str] | None, typer.Argument(
        help="Spec names or TOML paths (default: every shipped spec).")] = None,
    check: Annotated[bool, typer.Option(
        "--check", help="Only compare; exit 1 when generated/ is stale.")] = False,
    out: Annotated[Path | None, typer.Option(help="Generated root folder.")] = None,
):
    """Regenerate generated/<model>/ from equation specs (deterministic)."""
    from modelgen.codegen import generate as run_generate
    from modelgen.spec import shipped_spec_names

    names = specs or shipped_spec_names()
    changed = run_generate(names, root=out, check=check)
    if check:
        if changed:
            typer.echo("stale generated files (run `bearingdyn generate`):\n  "
                       + "\n  ".join(changed), err=True)
            raise typer.Exit(1)
        typer.echo(f"generated/ matches its specs ({', '.join(names)})")
    else:
        typer.echo(f"wrote {len(changed)} file(s)" + (": " + ", ".join(changed) if changed
                                                     else " (all up to date)"))


@app.command()
@reports_errors
def models():
    """List the generated models."""
    from analysis.model import available_models, load_model

    for name in available_models():
        m = load_model(name)
        typer.echo(f"{name:26s} N_b = {m.default_n_balls:2d}  sha256 {m.spec_sha256[:12]}  "
                   f"{m.module.TITLE}")


@app.command()
@reports_errors
def simulate(
    model: Annotated[str, typer.Argument(help="Model name, see `bearingdyn models`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.")],
    n_balls: Annotated[int | None, typer.Option(help="Number of balls.")] = None,
    speed_rpm: Annotated[float | None, typer.Option(help="Shaft speed, rpm.")] = None,
    sets: SetOption = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time, s.")] = None,
    transient: Annotated[float | None, typer.Option(help="Dropped initial time, s.")] = None,
    dt: Annotated[float | None, typer.Option(help="RK4 step and output spacing, s.")] = None,
    method: Annotated[str, typer.Option(help="rk4 (fixed step) or cvodes.")] = "rk4",
    save_every: Annotated[int, typer.Option(help="Keep every n-th step.")] = 1,
    no_compile: Annotated[bool, typer.Option(
        "--no-compile", help="Run RK4 in the CasADi VM instead of compiled C.")] = False,
):
    """Integrate a model and write the motion (x, y, vx, vy over t) to netCDF."""
    from analysis.integrate.simulate import simulate as run
    from analysis.io import save_dataset

    params = parse_sets(sets)
    if speed_rpm is not None:
        params["speed_rpm"] = speed_rpm
    start = time.perf_counter()
    ds = run(model, n_balls, duration=duration, transient=transient, dt=dt, method=method,
             save_every=save_every, compiled=not no_compile, **params)
    wall = time.perf_counter() - start
    save_dataset(ds, output)
    typer.echo(f"wrote {output}: {ds.attrs['model']}, N_b = {ds.attrs['n_balls']}, "
               f"{ds.attrs['speed_rpm']:g} rpm, t = {float(ds.t[0]):g}…{float(ds.t[-1]):g} s "
               f"({ds.sizes['t']} samples), {method} dt = {ds.attrs['dt']:g} s, "
               f"wall {wall:.2f} s")


@app.command()
@reports_errors
def spectrum(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the peaks as JSON.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.")] = None,
    max_peaks: Annotated[int, typer.Option(help="Peaks per direction.")] = 8,
):
    """Labelled spectral peaks (X, VC, VC−X, …) of a run, x and y directions."""
    from analysis.io import load_dataset
    from analysis.signal.spectrum import peak_table

    ds = load_dataset(run_file)
    peaks = peak_table(ds, max_peaks=max_peaks)
    if as_json:
        typer.echo(json.dumps({"shaft_hz": ds.attrs.get("shaft_hz"),
                               "vc_hz": ds.attrs.get("vc_hz"),
                               "peaks": [p.as_dict() for p in peaks]}, indent=2))
    else:
        typer.echo(f"X = {ds.attrs['shaft_hz']:.2f} Hz, VC = {ds.attrs['vc_hz']:.2f} Hz")
        typer.echo(f"{'dir':>3} {'frequency (Hz)':>15} {'amplitude (m)':>14}  label")
        for p in peaks:
            typer.echo(f"{p.direction:>3} {p.frequency_hz:15.2f} {p.amplitude:14.3e}  "
                       f"{p.label or '?'}")
    if output:
        from analysis.reports.plots import save_figure, spectrum_figure

        save_figure(spectrum_figure(ds), output)
        typer.echo(f"wrote {output}", err=as_json)


@app.command()
@reports_errors
def poincare(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    section: Annotated[str, typer.Option(help="shaft, cage or vc period.")] = "shaft",
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the points as JSON.")] = False,
):
    """Stroboscopic Poincaré section of a run (once per shaft, cage or VC period)."""
    from analysis.io import load_dataset
    from analysis.signal.poincare import SECTIONS, poincare_section

    if section not in SECTIONS:
        raise InputError(f"--section: must be one of {', '.join(SECTIONS)}, got {section!r}")
    ds = load_dataset(run_file)
    pts = poincare_section(ds, section)
    if as_json:
        typer.echo(json.dumps({v: pts[v].values.tolist() for v in ("t", "x", "y", "vx", "vy")}))
    else:
        typer.echo(f"{pts.sizes['k']} points on the {section} section "
                   f"(period {pts.attrs['section_period_s'] * 1e3:.4f} ms); "
                   f"x in [{float(pts.x.min()):.4e}, {float(pts.x.max()):.4e}] m, "
                   f"y in [{float(pts.y.min()):.4e}, {float(pts.y.max()):.4e}] m")
    if output:
        from analysis.reports.plots import poincare_figure, save_figure

        save_figure(poincare_figure(ds, section), output)
        typer.echo(f"wrote {output}", err=as_json)


def _parameters(speed_rpm: float | None, sets: list[str] | None) -> dict[str, float]:
    params = parse_sets(sets)
    if speed_rpm is not None:
        params["speed_rpm"] = speed_rpm
    return params


def _save_figure(fig, output: Path | None, err: bool = False) -> None:
    if output:
        from analysis.reports.plots import save_figure

        save_figure(fig, output)
        typer.echo(f"wrote {output}", err=err)


NBallsOption = Annotated[int | None, typer.Option(help="Number of balls.")]
SpeedOption = Annotated[float | None, typer.Option(help="Shaft speed, rpm.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result as JSON.")]


@app.command()
@reports_errors
def lyapunov(
    model: Annotated[str, typer.Argument(help="Model name.")],
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
    """Lyapunov spectrum (4 exponents, 1/s) from the tangent dynamics of the RK4 map."""
    from analysis.stability.lyapunov import lyapunov as run_lyapunov

    res = run_lyapunov(model, n_balls, duration=duration, transient=transient, dt=dt,
                       renorm_every=renorm_every, **_parameters(speed_rpm, sets))
    data = {"exponents": res.exponents.values.tolist(), "ci95": res.ci95.values.tolist(),
            "sum_of_exponents": res.attrs["sum_of_exponents"],
            "mean_divergence": res.attrs["mean_divergence"], "n_balls": res.attrs["n_balls"]}
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
    model: Annotated[str, typer.Argument(help="Model name.")],
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    period: Annotated[str, typer.Option(
        help="vc, shaft, vc:k, shaft:k or ratio:p/q (VC/X = p/q made exact).")] = "vc",
    segments: Annotated[int, typer.Option(help="Shooting segments (1: single).")] = 1,
    dt: Annotated[float, typer.Option(help="Largest RK4 step, s.")] = 1e-5,
    settle: Annotated[float, typer.Option(help="Simulated time for the guess, s.")] = 0.5,
    as_json: JsonOption = False,
):
    """Periodic orbit by Newton shooting, its Floquet multipliers and stability."""
    from analysis.stability.periodic import shoot

    orbit = shoot(model, n_balls, period, segments=segments, dt=dt, settle=settle,
                  **_parameters(speed_rpm, sets))
    if as_json:
        typer.echo(json.dumps(orbit.as_dict(), indent=2))
        return
    typer.echo(f"{orbit.model}, N_b = {orbit.n_balls}, period {orbit.period} = "
               f"{orbit.period_s:.6g} s ({orbit.n_steps} RK4 steps): {orbit.message}")
    typer.echo(f"z0 = {np.array2string(orbit.z0, precision=6)} (m, m/s) at t0 = {orbit.t0:g} s")
    for mu in orbit.multipliers:
        typer.echo(f"  μ = {mu.real:+.6f} {mu.imag:+.6f}i   |μ| = {abs(mu):.6f}")
    typer.echo(f"stability: {orbit.stability} (spectral radius {orbit.spectral_radius:.6f})")


@app.command()
@reports_errors
def classify(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    section: Annotated[str | None, typer.Option(
        help="shaft, cage or vc (default: vc for a balanced bearing, else shaft).")] = None,
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


@app.command("continue")
@reports_errors
def continue_(
    model: Annotated[str, typer.Argument(help="Model name.")],
    param: Annotated[str, typer.Option(help="Runtime parameter to vary.")],
    start: Annotated[float, typer.Option("--from", help="Start value (parameter unit).")],
    stop: Annotated[float, typer.Option("--to", help="End value (parameter unit).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the branch.")],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    period: Annotated[str, typer.Option(help="vc, shaft, vc:k, shaft:k, ratio:p/q.")] = "vc",
    dt: Annotated[float, typer.Option(help="Largest RK4 step, s.")] = 1e-5,
    settle: Annotated[float, typer.Option(help="Simulated time for the first guess, s.")] = 0.5,
    max_points: Annotated[int, typer.Option(help="Points per branch.")] = 200,
    ds_max: Annotated[float, typer.Option(help="Largest scaled arclength step.")] = 0.05,
    switch_pd: Annotated[bool, typer.Option(
        "--switch-pd", help="Also continue the period-2 branch from the first PD.")] = False,
    plot: Annotated[Path | None, typer.Option(help="Figure of the branch(es).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
):
    """Pseudo-arclength continuation of periodic orbits; LP, PD, NS, BP detection."""
    from analysis.io import save_dataset
    from analysis.stability import continuation as cont

    progress = None if quiet else typer.echo
    branch = cont.continue_orbits(model, n_balls, param=param, start=start, stop=stop,
                                  period=period, dt=dt, settle=settle, max_points=max_points,
                                  ds_max=ds_max, progress=progress, **parse_sets(sets))
    branches = [branch]
    if switch_pd:
        pds = np.nonzero(branch.special.values == "PD")[0]
        if len(pds) == 0:
            typer.echo("no period doubling on the branch: nothing to switch to", err=True)
        else:
            two = cont.switch_period_doubling(branch, int(pds[0]), dt=None)
            if not two.converged:
                typer.echo(f"branch switching failed: {two.message}", err=True)
            else:
                branches.append(cont.continue_from_orbit(
                    two, param=param, stop=stop, dt=dt, max_points=max_points,
                    ds_max=ds_max, progress=progress, label=f"period {two.period}"))
    for i, br in enumerate(branches):
        path = output if i == 0 else output.with_name(f"{output.stem}-period2{output.suffix}")
        save_dataset(br, path)
        specials = [f"{k} at {br[param].values[j]:.6g}" for j, k in
                    enumerate(br.special.values) if k]
        typer.echo(f"wrote {path}: {br.sizes['point']} orbits ({br.attrs['branch']}), "
                   f"{br.attrs['status']}; special points: {', '.join(specials) or 'none'}")
    if plot:
        from analysis.reports.plots import branch_figure

        _save_figure(branch_figure(branches), plot)


ExecutorOption = Annotated[str, typer.Option(
    "--executor", help="serial, processes (all cores) or dask (a LocalCluster).")]
WorkersOption = Annotated[int | None, typer.Option(help="Worker processes (default: cores).")]
SchedulerOption = Annotated[str | None, typer.Option(
    help="Address of a running Dask scheduler, tcp://host:port.")]
QuietOption = Annotated[bool, typer.Option("--quiet", help="No progress output.")]


def _executor(kind: str, workers: int | None, scheduler: str | None):
    from analysis.sweeps.executors import make_executor

    return make_executor(kind, workers, scheduler)


@app.command()
@reports_errors
def sweep(
    model: Annotated[str, typer.Argument(help="Model name.")],
    param: Annotated[str, typer.Option(help="Parameter on the grid (or n_balls).")],
    start: Annotated[float, typer.Option("--from", help="First value.")],
    stop: Annotated[float, typer.Option("--to", help="Last value.")],
    num: Annotated[int, typer.Option(help="Number of grid values.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.")],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    direction: Annotated[str, typer.Option(help="up, down or both.")] = "up",
    follow: Annotated[bool, typer.Option(
        help="Start each value from the previous end state (shows hysteresis).")] = True,
    transient: Annotated[float, typer.Option(help="Dropped time per value, s.")] = 1.0,
    samples: Annotated[int, typer.Option(help="Poincaré points per value.")] = 200,
    section: Annotated[str, typer.Option(help="shaft, cage or vc.")] = "shaft",
    dt: Annotated[float, typer.Option(help="RK4 step, s.")] = 1e-5,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
):
    """Brute-force bifurcation diagram over one parameter (resumable: re-run to continue)."""
    from analysis.reports.progress import ProgressReporter
    from analysis.sweeps.sweep import Axis, Setting, bifurcation_diagram

    setting = Setting(model, n_balls, parse_sets(sets), transient, samples, section, dt)
    ex = _executor(executor, workers, scheduler)
    try:
        ds = bifurcation_diagram(setting, Axis.linear(param, start, stop, num), output,
                                 direction=direction, follow=follow, executor=ex,
                                 progress=ProgressReporter(f"sweep {param}", quiet))
    finally:
        ex.close()
    typer.echo(f"wrote {output}: {ds.sizes[param]} values × {ds.sizes['direction']} "
               f"direction(s), {samples} section points each ({ex.name})")


@app.command()
@reports_errors
def chart(
    model: Annotated[str, typer.Argument(help="Model name.")],
    x: Annotated[str, typer.Option(help="x axis name:start:stop:count, e.g. "
                                        "speed_rpm:1000:10000:200.")],
    y: Annotated[str, typer.Option(help="y axis, e.g. n_balls:5:12.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.")],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    transient: Annotated[float, typer.Option(help="Dropped time per point, s.")] = 1.0,
    revolutions: Annotated[int, typer.Option(help="Recorded shaft revolutions.")] = 200,
    lyapunov: Annotated[bool, typer.Option(help="Largest Lyapunov exponent at every "
                                                "point.")] = True,
    dt: Annotated[float, typer.Option(help="RK4 step, s.")] = 1e-5,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
    table: Annotated[bool, typer.Option("--table", help="Print the chart as a table.")] = False,
):
    """Stability chart: periodic-n / quasi-periodic / chaotic on a 2-D grid (resumable)."""
    from analysis.reports.progress import ProgressReporter
    from analysis.sweeps.sweep import Axis, Setting, chart_table, stability_chart

    setting = Setting(model, n_balls, parse_sets(sets), transient, revolutions, "shaft", dt,
                      lyapunov)
    ex = _executor(executor, workers, scheduler)
    try:
        ds = stability_chart(setting, Axis.parse(x), Axis.parse(y), output, executor=ex,
                             progress=ProgressReporter("chart", quiet))
    finally:
        ex.close()
    typer.echo(f"wrote {output}: {ds.sizes[ds.attrs['y']]} × {ds.sizes[ds.attrs['x']]} "
               f"points ({ex.name})")
    if table:
        typer.echo(chart_table(ds))


@app.command()
@reports_errors
def plot(
    result: Annotated[Path, typer.Argument(help="Any bearingdyn netCDF result.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Figure file (PNG, PDF, SVG).")],
):
    """Draw the natural figure of a result file (run, branch, diagram or chart)."""
    from analysis.io import open_result
    from analysis.reports.plots import any_figure

    _save_figure(any_figure(open_result(result)), output)


@app.command()
@reports_errors
def reproduce(
    model: Annotated[str, typer.Argument(help="The paper's model.")] = "vakharia2015",
    out_dir: Annotated[Path, typer.Option("-o", "--out-dir", help="Report folder.")] = Path(
        "bearingdyn-reproduction"),
    quick: Annotated[bool, typer.Option(
        "--quick", help="Short runs and two values per sensitivity parameter (a smoke test; "
                        "verdicts less reliable).")] = False,
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
    from analysis.reports.reproduce import reproduce as run_reproduce

    kwargs = {}
    if quick:
        kwargs = dict(duration=1.6, transient=0.6, revolutions=60,
                      sensitivity={k: (min(v), max(v)) for k, v in SENSITIVITY.items()})
    ex = _executor(executor, workers, scheduler)
    try:
        rep = run_reproduce(out_dir, model, executor=ex, log=None if quiet else typer.echo,
                            progress_factory=lambda label: ProgressReporter(label, quiet),
                            **kwargs)
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
    model: Annotated[str, typer.Option(help="Model name.")] = "vakharia2015",
    n_balls: Annotated[list[int] | None, typer.Option(
        help="Numbers of balls (repeatable; default 6 7 8 9 10).")] = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time, s.")] = None,
    transient: Annotated[float | None, typer.Option(help="Dropped initial time, s.")] = None,
    sets: SetOption = None,
):
    """The default job: the paper's case for N_b = 6…10 (netCDF + figure per N_b, peak table)."""
    from analysis.reports.paper import PAPER_N_BALLS
    from analysis.reports.report import peak_table_markdown, run_paper_case

    results = run_paper_case(out_dir, model, n_balls or PAPER_N_BALLS, duration, transient,
                             progress=typer.echo, **parse_sets(sets))
    typer.echo("\n" + peak_table_markdown(results))
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

    Runs benchmarks/bench_simulate.py of a source checkout (the benchmarks are not installed).
    """
    if repeat < 1:
        raise InputError(f"--repeat: must be >= 1, got {repeat}")
    if not duration > 0 or memory_duration < 0:
        raise InputError(f"--duration: must be > 0 s and --memory-duration >= 0 s, got "
                         f"{duration:g} and {memory_duration:g}")
    bench_module = _benchmark_module()
    res = bench_module.run_benchmark(repeat, duration, memory_duration,
                                     progress=lambda msg: typer.echo(msg, err=True))
    typer.echo(bench_module.format_result(res))


BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
"""``benchmarks/`` of the source checkout this package runs from (absent when installed)."""


def _benchmark_module():
    """benchmarks/bench_simulate.py, loaded by path (it is not part of the package)."""
    import importlib.util
    import sys

    path = BENCHMARKS / "bench_simulate.py"
    if not path.is_file():
        raise BearingdynError(
            f"the benchmarks live in the source tree, not in the installed package ({path} "
            "not found): in a checkout of bearingdyn run `python benchmarks/bench_simulate.py`")
    spec = importlib.util.spec_from_file_location("bench_simulate", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it executes
    spec.loader.exec_module(module)
    return module


if __name__ == "__main__":
    app()
