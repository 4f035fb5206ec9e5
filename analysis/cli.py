"""The ``bearingdyn`` command."""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path
from typing import Annotated

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
):
    """Integrate a model and write the motion (x, y, vx, vy over t) to netCDF."""
    from analysis.io import save_dataset
    from analysis.simulate import simulate as run

    params = parse_sets(sets)
    if speed_rpm is not None:
        params["speed_rpm"] = speed_rpm
    start = time.perf_counter()
    ds = run(model, n_balls, duration=duration, transient=transient, dt=dt, method=method,
             save_every=save_every, **params)
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
    from analysis.spectrum import peak_table

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
        from analysis.plots import save_figure, spectrum_figure

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
    from analysis.poincare import SECTIONS, poincare_section

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
        from analysis.plots import poincare_figure, save_figure

        save_figure(poincare_figure(ds, section), output)
        typer.echo(f"wrote {output}", err=as_json)


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
    from analysis.report import PAPER_N_BALLS, peak_table_markdown, run_paper_case

    results = run_paper_case(out_dir, model, n_balls or PAPER_N_BALLS, duration, transient,
                             progress=typer.echo, **parse_sets(sets))
    typer.echo("\n" + peak_table_markdown(results))
    typer.echo(f"results in {out_dir}/ (nb<N>.nc, nb<N>.png, peaks.md, peaks.json)")


if __name__ == "__main__":
    app()
