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

MODEL_HELP = ("Model: a shipped name or a name in a BEARINGDYN_MODELS folder (see `bearingdyn "
              "models`), the path of a .toml spec, or a folder written by `bearingdyn "
              "generate SPEC --out DIR`.")
ModelArgument = Annotated[str, typer.Argument(help=MODEL_HELP, metavar="MODEL")]


def parse_n_balls(items: list[str] | None) -> int | dict[str, int] | None:
    """``["8"]`` -> 8 (a model with one bearing); ``["left=7", "right=11"]`` (or
    ``["left=7,right=11"]``) -> {"left": 7, "right": 11}; nothing -> None (the spec's)."""
    parts = [part.strip() for item in items or [] for part in str(item).split(",")
             if part.strip()]
    if not parts:
        return None
    named: dict[str, int] = {}
    plain: list[int] = []
    for part in parts:
        name, sep, text = part.partition("=")
        try:
            number = int(text if sep else name)
        except ValueError:
            raise typer.BadParameter(
                f"expected a whole number (8) or bearing=number (left=8), got {part!r}",
                param_hint="'--n-balls'") from None
        if sep:
            if not name.strip():
                raise typer.BadParameter(f"a bearing name is missing in {part!r}",
                                         param_hint="'--n-balls'")
            named[name.strip()] = number
        else:
            plain.append(number)
    if plain and (named or len(plain) > 1):
        raise typer.BadParameter("give one number (a model with one bearing) or "
                                 "bearing=number for each bearing (repeatable), got "
                                 f"{', '.join(parts)}", param_hint="'--n-balls'")
    return plain[0] if plain else named


def _check_n_balls(items: list[str] | None) -> list[str] | None:
    parse_n_balls(items)  # a bad value is a usage error of the command line
    return items


NBallsOption = Annotated[list[str] | None, typer.Option(
    help="Balls: a number for a model with one bearing, or bearing=number for each bearing "
         "of a model with several (repeatable: --n-balls left=8 --n-balls right=10).",
    callback=_check_n_balls)]


def frequency_words(attrs) -> str:
    """``X = 83.33 Hz, VC = 199.34 Hz`` (``VC[left] = …`` per bearing; ``F = …`` for a model
    forced at a parameter's period)."""
    from analysis.signal import cage_frequencies, vc_frequencies

    words = []
    if float(attrs.get("shaft_hz", 0.0)) > 0:
        words.append(f"X = {float(attrs['shaft_hz']):.2f} Hz")
    cages = cage_frequencies(attrs)
    for bearing, vc in vc_frequencies(attrs).items():
        name = f"VC[{bearing}]" if bearing else "VC"
        cage = cages.get(bearing)
        words.append(f"{name} = {vc:.2f} Hz" + (f" (cage {cage:.2f} Hz)" if cage else ""))
    if not words and float(attrs.get("forcing_period", 0.0)) > 0:
        words.append(f"F = 1/forcing_period = {1 / float(attrs['forcing_period']):.4g} Hz")
    return ", ".join(words) or "no characteristic frequency"


@app.command()
@reports_errors
def generate(
    specs: Annotated[list[str] | None, typer.Argument(
        help="Spec names (shipped or in BEARINGDYN_MODELS) or .toml paths (default: every "
             "shipped spec).")] = None,
    check: Annotated[bool, typer.Option(
        "--check", help="Only compare; exit 1 when the generated code is stale.")] = False,
    out: Annotated[Path | None, typer.Option(
        help="Folder to write a loadable model into (give it to any command in place of a "
             "model name). Default: generated/ for shipped specs, the user cache for others "
             "(never the package).")] = None,
):
    """Generate a model's code from its equation spec (deterministic).

    Shipped specs go to the package's generated/; any other spec goes to the user cache
    (where `bearingdyn simulate SPEC.toml` finds it), or to --out DIR.
    """
    from modelgen.codegen import default_root
    from modelgen.codegen import generate as run_generate
    from modelgen.locations import cached_model_root, is_shipped
    from modelgen.spec import load_spec, shipped_spec_names

    names = specs or shipped_spec_names()
    changed = run_generate(names, root=out, check=check)
    targets: dict[Path, list[str]] = {}
    for name in names:
        _, path = load_spec(name)
        target = out if out is not None else (
            default_root() if is_shipped(path) else cached_model_root(path))
        targets.setdefault(Path(target), []).append(str(name))
    if check:
        if changed:
            typer.echo("stale generated files (run `bearingdyn generate`):\n  "
                       + "\n  ".join(changed), err=True)
            raise typer.Exit(1)
        inside = [n for t, ns in targets.items() if t == default_root() for n in ns]
        outside = {t: ns for t, ns in targets.items() if t != default_root()}
        if inside:
            typer.echo(f"generated/ matches its specs ({', '.join(inside)})")
        for target, ns in outside.items():
            typer.echo(f"{target} matches its specs ({', '.join(ns)})")
        return
    typer.echo(f"wrote {len(changed)} file(s)" + (": " + ", ".join(changed) if changed
                                                 else " (all up to date)"))
    for target, ns in targets.items():
        if target == default_root():
            typer.echo(f"{', '.join(ns)}: in the package's generated/")
        elif out is not None:
            typer.echo(f"{', '.join(ns)}: in {target.resolve()} (load it by giving that folder "
                       "as the model, e.g. `bearingdyn simulate " + str(target) + " -o run.nc`)")
        else:
            typer.echo(f"{', '.join(ns)}: in the user cache, {target} (commands given the "
                       "spec's path or name load it from there)")


@app.command()
@reports_errors
def models():
    """List the shipped models and the specs in BEARINGDYN_MODELS folders: origin, state
    size n, bearings with their default balls, spec hash and title."""
    from analysis.model import available_models, load_model, model_origin
    from modelgen.errors import SpecError

    for name in available_models():
        origin = model_origin(name)
        try:
            m = load_model(name)
        except (BearingdynError, SpecError) as exc:
            typer.echo(f"{name:26s} {origin}: cannot load ({exc})")
            continue
        bearings = ", ".join(f"{b.name} {b.default_n_balls} balls" for b in m.bearings) \
            or "no bearings"
        typer.echo(f"{name:26s} {origin:8s} n = {m.n_state:2d}  {bearings:30s} "
                   f"sha256 {m.spec_sha256[:12]}  {m.module.TITLE}")


@app.command()
@reports_errors
def simulate(
    model: ModelArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.")],
    n_balls: NBallsOption = None,
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
    """Integrate a model and write its motion (every state variable over t) to netCDF."""
    from analysis.integrate.simulate import simulate as run
    from analysis.io import save_dataset
    from analysis.model import balls_text

    params = parse_sets(sets)
    if speed_rpm is not None:
        params["speed_rpm"] = speed_rpm
    start = time.perf_counter()
    ds = run(model, parse_n_balls(n_balls), duration=duration, transient=transient, dt=dt,
             method=method, save_every=save_every, compiled=not no_compile, **params)
    wall = time.perf_counter() - start
    save_dataset(ds, output)
    speed = f"{ds.attrs['speed_rpm']:g} rpm, " if "speed_rpm" in ds.attrs else ""
    typer.echo(f"wrote {output}: {ds.attrs['model']}, {balls_text(ds.attrs)}, {speed}"
               f"t = {float(ds.t[0]):g}…{float(ds.t[-1]):g} s ({ds.sizes['t']} samples), "
               f"{method} dt = {ds.attrs['dt']:g} s, wall {wall:.2f} s; variables "
               f"{', '.join(ds.attrs['state_names'].split())}")


@app.command()
@reports_errors
def spectrum(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the peaks as JSON.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.")] = None,
    max_peaks: Annotated[int, typer.Option(help="Peaks per variable.")] = 8,
    var: Annotated[list[str] | None, typer.Option(
        "--var", help="State variable to analyse, repeatable (default: the first body's "
                      "displacements, x and y).")] = None,
):
    """Labelled spectral peaks (X, VC, VC−X, …; VC[left], VC[right] for several bearings)
    of a run's displacements or of any state variables."""
    from analysis.io import load_dataset
    from analysis.signal import cage_frequencies, displacement_names, vc_frequencies
    from analysis.signal.spectrum import peak_table

    ds = load_dataset(run_file)
    variables = tuple(var) if var else displacement_names(ds)
    peaks = peak_table(ds, variables, max_peaks=max_peaks)
    if as_json:
        typer.echo(json.dumps({"shaft_hz": ds.attrs.get("shaft_hz"),
                               "vc_hz": ds.attrs.get("vc_hz"),
                               "vc": vc_frequencies(ds.attrs),
                               "cage": cage_frequencies(ds.attrs),
                               "peaks": [p.as_dict() for p in peaks]}, indent=2))
    else:
        typer.echo(frequency_words(ds.attrs))
        width = max(3, *(len(v) for v in variables))
        typer.echo(f"{'var':>{width}} {'frequency (Hz)':>15} {'amplitude':>14}  label")
        for p in peaks:
            unit = ds[p.direction].attrs.get("units", "")
            typer.echo(f"{p.direction:>{width}} {p.frequency_hz:15.2f} "
                       f"{p.amplitude:10.3e} {unit:<4} {p.label or '?'}")
    if output:
        from analysis.reports.plots import save_figure, spectrum_figure

        save_figure(spectrum_figure(ds, variables), output)
        typer.echo(f"wrote {output}", err=as_json)


@app.command()
@reports_errors
def poincare(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    section: Annotated[str, typer.Option(
        help="shaft, cage or vc period (of the first bearing), cage[BEARING], vc[BEARING], "
             "or param:NAME (the period in s held by parameter NAME, e.g. "
             "param:forcing_period).")] = "shaft",
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the points as JSON.")] = False,
    x: Annotated[str | None, typer.Option(
        "--x", help="State variable on the figure's horizontal axis (default: each "
                    "displacement of the first body, against its velocity).")] = None,
    y: Annotated[str | None, typer.Option(
        "--y", help="State variable on the vertical axis (default: the velocity of --x).")
    ] = None,
):
    """Stroboscopic Poincaré section of a run (once per shaft, cage, VC or parameter
    period); every state variable is sampled."""
    from analysis.io import load_dataset
    from analysis.signal import displacement_names, run_state_names
    from analysis.signal.poincare import SECTION_SYNTAX, parse_section, poincare_section

    try:
        parse_section(section)  # the syntax, before the file is read
    except InputError:
        raise InputError(f"--section: must be {SECTION_SYNTAX}, got {section!r}") from None
    ds = load_dataset(run_file)
    names = run_state_names(ds)
    for option, name in (("--x", x), ("--y", y)):
        if name is not None and name not in names:
            raise InputError(f"{option}: no state variable {name!r} in this run; "
                             f"variables: {', '.join(names)}")
    if y is not None and x is None:
        raise InputError("--y: give --x too")
    try:
        pts = poincare_section(ds, section)
    except InputError as exc:
        if str(exc).startswith("section: must be"):
            raise InputError(f"--section: must be {SECTION_SYNTAX}, got {section!r}") from None
        raise
    shown = (x, y) if x else displacement_names(ds)
    if as_json:
        typer.echo(json.dumps({v: pts[v].values.tolist() for v in ("t", *names)}))
    else:
        ranges = ", ".join(f"{v} in [{float(pts[v].min()):.4e}, {float(pts[v].max()):.4e}] "
                           f"{pts[v].attrs.get('units', '')}".rstrip()
                           for v in shown if v is not None)
        typer.echo(f"{pts.sizes['k']} points on the {section} section "
                   f"(period {pts.attrs['section_period_s'] * 1e3:.4f} ms); {ranges}")
    if output:
        from analysis.reports.plots import poincare_figure, save_figure

        save_figure(poincare_figure(ds, section, [(x, y)] if x else None), output)
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


SpeedOption = Annotated[float | None, typer.Option(help="Shaft speed, rpm.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result as JSON.")]


PERIOD_HELP = ("vc, shaft, vc:k, shaft:k, ratio:p/q (VC/X = p/q made exact), vc[BEARING] "
               "(a model with several bearings) or param:NAME (the period in s held by "
               "parameter NAME, e.g. param:forcing_period); default: the model's natural "
               "period (vc with one bearing, param:forcing_period or shaft without).")
PeriodOption = Annotated[str | None, typer.Option(help=PERIOD_HELP)]


def _given(**options) -> dict:
    """The options the user gave (None: leave the API's default)."""
    return {k: v for k, v in options.items() if v is not None}


def _orbit_structure(orbit) -> str:
    structure = getattr(orbit, "structure", None)
    if structure is None:
        return f"N_b = {getattr(orbit, 'n_balls', '?')}"
    if not structure:
        return "no balls"
    return ", ".join(f"{n}" for n in structure) + " balls"


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


@app.command("continue")
@reports_errors
def continue_(
    model: ModelArgument,
    param: Annotated[str, typer.Option(help="Runtime parameter to vary.")],
    start: Annotated[float, typer.Option("--from", help="Start value (parameter unit).")],
    stop: Annotated[float, typer.Option("--to", help="End value (parameter unit).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file of the branch.")],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    period: PeriodOption = None,
    dt: Annotated[float | None, typer.Option(
        help="Largest RK4 step, s (default: the spec's).")] = None,
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
    branch = cont.continue_orbits(model, parse_n_balls(n_balls), param=param, start=start,
                                  stop=stop, period=period, settle=settle,
                                  max_points=max_points, ds_max=ds_max, progress=progress,
                                  **_given(dt=dt), **parse_sets(sets))
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
                    two, param=param, stop=stop, max_points=max_points, ds_max=ds_max,
                    progress=progress, label=f"period {two.period}", **_given(dt=dt)))
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
    model: ModelArgument,
    param: Annotated[str, typer.Option(
        help="Runtime parameter on the grid, or n_balls (a model with one bearing) / "
             "n_balls[BEARING] (several).")],
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
    section: Annotated[str, typer.Option(
        help="shaft, cage, vc, cage[BEARING], vc[BEARING] or param:NAME.")] = "shaft",
    dt: Annotated[float, typer.Option(help="RK4 step, s.")] = 1e-5,
    executor: ExecutorOption = "processes",
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    quiet: QuietOption = False,
):
    """Brute-force bifurcation diagram over one parameter (resumable: re-run to continue)."""
    from analysis.reports.progress import ProgressReporter
    from analysis.sweeps.sweep import Axis, Setting, bifurcation_diagram

    setting = Setting(model, parse_n_balls(n_balls), parse_sets(sets), transient, samples,
                      section, dt)
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
    model: ModelArgument,
    x: Annotated[str, typer.Option(help="x axis name:start:stop:count, e.g. "
                                        "speed_rpm:1000:10000:200.")],
    y: Annotated[str, typer.Option(help="y axis, e.g. n_balls:5:12 (one bearing) or "
                                        "n_balls[left]:5:12 (several).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.")],
    n_balls: NBallsOption = None,
    sets: SetOption = None,
    transient: Annotated[float, typer.Option(help="Dropped time per point, s.")] = 1.0,
    revolutions: Annotated[int, typer.Option(
        help="Recorded periods of the section (shaft revolutions by default).")] = 200,
    section: Annotated[str, typer.Option(
        help="Section the points are classified on: shaft, cage, vc, cage[BEARING], "
             "vc[BEARING] or param:NAME.")] = "shaft",
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

    setting = Setting(model, parse_n_balls(n_balls), parse_sets(sets), transient, revolutions,
                      section, dt, lyapunov)
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
    var: Annotated[list[str] | None, typer.Option(
        "--var", help="State variable to draw, repeatable (a diagram's section points, or a "
                      "run's spectra; default: the first body's displacements).")] = None,
):
    """Draw the natural figure of a result file (run, branch, diagram or chart)."""
    from analysis.io import open_result
    from analysis.reports.plots import any_figure

    _save_figure(any_figure(open_result(result), var), output)


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
    model: Annotated[str, typer.Option(help=MODEL_HELP)] = "vakharia2015",
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
