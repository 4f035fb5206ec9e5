"""What every command shares: the typer app, the error edge, option types and parsers."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Annotated

import typer

from analysis.errors import BearingdynError, InputError

app = typer.Typer(no_args_is_help=True, rich_markup_mode=None, add_completion=False,
                  pretty_exceptions_enable=False,
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


ExecutorOption = Annotated[str, typer.Option(
    "--executor", help="serial, processes (all cores) or dask (a LocalCluster).")]
WorkersOption = Annotated[int | None, typer.Option(help="Worker processes (default: cores).")]
SchedulerOption = Annotated[str | None, typer.Option(
    help="Address of a running Dask scheduler, tcp://host:port.")]
QuietOption = Annotated[bool, typer.Option("--quiet", help="No progress output.")]


def _executor(kind: str, workers: int | None, scheduler: str | None):
    from analysis.sweeps.executors import make_executor

    return make_executor(kind, workers, scheduler)
