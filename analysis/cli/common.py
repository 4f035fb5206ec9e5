"""What every command shares: the typer app, the error edge, option types and parsers."""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Annotated

import typer

try:  # typer >= 0.24 carries its own copy of click; older ones use click itself
    from typer import _click as click
except ImportError:  # pragma: no cover
    import click

from analysis.errors import BearingdynError, InputError, WriteError

app = typer.Typer(no_args_is_help=True, rich_markup_mode=None, add_completion=False,
                  pretty_exceptions_enable=False,
                  help="Rotor-ball-bearing models from equation specs: generate, simulate, "
                       "analyse. SI units; speeds in rpm.")
_state = {"debug": False, "said": False}
"""``said``: the error edge printed its line (``_fail``), so an exit code needs no other."""


@app.callback()
def _main(debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks.")] = False):
    _state["debug"] = debug


def reports_errors(command):
    """The error edge of every command: nothing reaches the user as a traceback.

    - a user error (``BearingdynError``, ``SpecError``): ``error: <message>``, exit code 2;
    - a file system failure (full disk, permission, name too long): one line naming the
      file, exit code 1;
    - Ctrl-C: ``interrupted``, exit code 130 (atomic writes leave no partial file);
    - anything else: ``internal error: <type>: <message>``, exit code 1.

    ``bearingdyn --debug`` re-raises instead, so the traceback shows."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from modelgen.errors import SpecError

        try:
            return command(*args, **kwargs)
        except (typer.Exit, typer.Abort):
            raise
        except click.exceptions.BadParameter as exc:
            hint = exc.param_hint or (exc.param.opts[0] if exc.param else "option")
            hint = hint if isinstance(hint, str) else " / ".join(hint)
            _fail(exc, f"error: {hint.strip(chr(39))}: {exc.message}", 2)
        except click.exceptions.ClickException as exc:
            _fail(exc, f"error: {exc.format_message()}", 2)
        except WriteError as exc:  # not the user's input: the disk or the file system
            _fail(exc, f"error: {exc}", 1)
        except (BearingdynError, SpecError) as exc:
            _fail(exc, f"error: {as_option(exc)}", 2)
        except KeyboardInterrupt as exc:
            _fail(exc, "interrupted (nothing half-written was left)", 130)
        except BrokenPipeError:  # the reader of stdout went away (`| head`): end quietly
            closed_pipe()
        except OSError as exc:
            where = f" '{exc.filename}'" if exc.filename else ""
            _fail(exc, f"error: cannot use{where}: {exc.strerror or exc}", 1)
        except MemoryError as exc:
            _fail(exc, "error: out of memory; try a shorter run or a coarser grid", 1)
        except Exception as exc:  # the edge: one line, never a traceback
            text = " ".join(str(exc).split())[:300]
            _fail(exc, f"internal error: {type(exc).__name__}: {text} (run with --debug "
                       "for the traceback)", 1)

    return wrapper


NULL_NOTE = ("null stands for a number that could not be computed (NaN) or is infinite: "
             "strict JSON has neither")
"""The note that ``echo_json`` adds where it wrote ``null`` for a non-finite number."""


def _finite(value, replaced: list[bool]):
    """``value`` with every NaN or infinite number (Python or numpy, at any depth) as None."""
    from analysis.provenance import plain

    if isinstance(value, dict):
        return {key: _finite(item, replaced) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(item, replaced) for item in value]
    converted = plain(value)
    if isinstance(converted, list):
        return _finite(converted, replaced)
    if isinstance(converted, float) and not math.isfinite(converted):
        replaced[0] = True
        return None
    return converted


def echo_json(data: dict, indent: int | None = 2) -> None:
    """Print ``data`` as strict JSON: NaN and infinities become ``null``, and then a
    top-level ``"notes"`` entry says so (``NULL_NOTE``)."""
    import json

    replaced = [False]
    data = _finite(data, replaced)
    if replaced[0]:
        data = {**data, "notes": [*data.get("notes", []), NULL_NOTE]}
    typer.echo(json.dumps(data, indent=indent, allow_nan=False))


def _fail(exc: BaseException, line: str, code: int) -> None:
    if _state["debug"]:
        raise exc
    typer.echo(line, err=True)
    _state["said"] = True
    for note in getattr(exc, "__notes__", ()):  # e.g. a sweep's points kept, how to resume
        typer.echo(note, err=True)
    raise typer.Exit(code) from None


def parse_sets(items: list[str] | None) -> dict[str, float]:
    """``["damping=100", "radial_load=20"]`` -> {"damping": 100.0, "radial_load": 20.0}.

    A parameter given twice is refused (which one was meant?), and so is ``n_balls``: the
    balls are structure, given with ``--n-balls``."""
    values: dict[str, float] = {}
    for item in items or []:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(f"--set: expected name=value, got {item!r}")
        if name == "n_balls" or name.startswith("n_balls["):
            raise InputError(f"--set {name}: the number of balls is structure, not a "
                             f"parameter; give it with --n-balls")
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"--set {name}: value must be a number, got {text!r}") from None
        if name in values:
            raise InputError(f"--set {name}: given twice ({values[name]:g} and {value:g}); "
                             "give each parameter once")
        values[name] = value
    return values


def parameter_values(speed_rpm: str | float | None, sets: list[str] | None
                     ) -> dict[str, float]:
    """``--set`` values with ``--speed-rpm`` merged in (refused when both give the speed).
    ``--speed-rpm`` is one speed here: a ramp or a speed table is refused in one line (only
    ``simulate`` follows one, through ``run_speed``).

    >>> parameter_values("3000", ["damping=100"])
    {'damping': 100.0, 'speed_rpm': 3000.0}
    """
    params = parse_sets(sets)
    speed_rpm = _one_speed(speed_rpm)
    if speed_rpm is not None:
        if "speed_rpm" in params:
            raise InputError(f"--speed-rpm: given twice (--speed-rpm {speed_rpm:g} and --set "
                             f"speed_rpm={params['speed_rpm']:g}); give the speed once")
        params["speed_rpm"] = speed_rpm
    return params


def _one_speed(speed_rpm: str | float | None) -> float | None:
    if speed_rpm is None or isinstance(speed_rpm, (int, float)):
        return speed_rpm
    from analysis.integrate.speed_profile import SpeedProfile, parse_speed

    speed = parse_speed(speed_rpm)
    if isinstance(speed, SpeedProfile):
        raise InputError(f"--speed-rpm: one speed in rpm here (a ramp or a speed table is "
                         f"for simulate), got {speed_rpm!r}")
    return speed


def run_speed(speed_rpm: str | None, sets: list[str] | None):
    """``(parameters, profile)`` of a run: ``--set`` values with the speed merged in, and
    the ``SpeedProfile`` of a ramp or speed table given to ``--speed-rpm`` (None at one
    speed; ``speed_rpm`` is then the profile's speed at t = 0)."""
    from analysis.integrate.speed_profile import SpeedProfile, parse_speed

    speed = None if speed_rpm is None else parse_speed(speed_rpm)
    profile = speed if isinstance(speed, SpeedProfile) else None
    params = parameter_values(profile.start_rpm if profile else speed, sets)
    return params, profile


SetOption = Annotated[list[str] | None, typer.Option(
    "--set", help="Parameter override name=value (SI units), repeatable.")]

MODEL_HELP = ("Model: a shipped name or a name in a BEARINGDYN_MODELS folder (see `bearingdyn "
              "models`), the path of a .toml spec, or a folder written by `bearingdyn "
              "generate SPEC --out DIR`.")


def judge_spec(value: str | None) -> str | None:
    """Argument callback: a spec of your own that will be generated is judged now, before
    the command imports its libraries (``modelgen.early``)."""
    from modelgen.early import judge_spec_early

    return judge_spec_early(value) if isinstance(value, str) else value


ModelArgument = Annotated[str, typer.Argument(help=MODEL_HELP, metavar="MODEL",
                                              callback=judge_spec, is_eager=True)]
ModelOption = Annotated[str, typer.Option("--model", help=MODEL_HELP, callback=judge_spec,
                                          is_eager=True)]
"""``--model MODEL`` (``bearingdyn run``): judged as the MODEL argument is."""


def parse_n_balls(items: list[str] | int | dict[str, int] | None
                  ) -> int | dict[str, int] | None:
    """``["8"]`` -> 8 (a model with one bearing); ``["left=7", "right=11"]`` (or
    ``["left=7,right=11"]``) -> {"left": 7, "right": 11}; nothing -> None (the spec's).
    Balls already parsed (an int or a dict) come back as they are.

    >>> parse_n_balls(["8"]), parse_n_balls(["left=7,right=11"]), parse_n_balls(None)
    (8, {'left': 7, 'right': 11}, None)
    """
    if isinstance(items, (int, dict)):
        return items
    parts = [part.strip() for item in items or [] for part in str(item).split(",")
             if part.strip()]
    if not parts:
        return None
    named: dict[str, int] = {}
    plain: list[int] = []
    for part in parts:
        name, number = _ball_count(part)
        if name is None:
            plain.append(number)
        elif name in named:
            raise _balls_error(f"bearing {name!r} given twice ({named[name]} and {number}); "
                               "give each bearing once")
        else:
            named[name] = number
    if plain and (named or len(plain) > 1):
        raise _balls_error("give one number (a model with one bearing) or bearing=number for "
                           f"each bearing (repeatable), got {', '.join(parts)}")
    return plain[0] if plain else named


def _balls_error(text: str) -> typer.BadParameter:
    return typer.BadParameter(text, param_hint="'--n-balls'")


def _ball_count(part: str) -> tuple[str | None, int]:
    """``"8"`` -> (None, 8); ``"left=8"`` -> ("left", 8)."""
    name, sep, text = part.partition("=")
    try:
        number = int(text if sep else name)
    except ValueError:
        raise _balls_error(f"expected a whole number (8) or bearing=number (left=8), got "
                           f"{part!r}") from None
    if sep and not name.strip():
        raise _balls_error(f"a bearing name is missing in {part!r}")
    return (name.strip() if sep else None), number


def _check_n_balls(items: list[str] | None) -> list[str] | None:
    """A bad value is a usage error of the command line, found while the options are read.
    The items go on as they came: typer turns whatever the callback of a repeatable option
    returns back into a list (``list(value)``: 8 would fail, a dict would lose its counts),
    so the command parses them once, with ``parse_n_balls``."""
    parse_n_balls(items)
    return items


NBallsOption = Annotated[list[str] | None, typer.Option(
    help="Balls: a number for a model with one bearing, or bearing=number for each bearing "
         "of a model with several (repeatable: --n-balls left=8 --n-balls right=10).",
    callback=_check_n_balls)]


def _check_output_option(param: typer.CallbackParam, value: Path | None,
                         suffixes: tuple[str, ...] | None) -> Path | None:
    from analysis.io import check_output

    if value is not None:
        option = max(param.opts, key=len) if param.opts else "--output"
        try:
            check_output(value, suffixes, option)
        except InputError as exc:
            raise typer.BadParameter(str(exc).removeprefix(f"{option}: "),
                                     param_hint=option) from None
    return value


def netcdf_output(param: typer.CallbackParam, value: Path | None) -> Path | None:
    """Option callback: ``value`` can be written as a netCDF result (checked at once,
    before the command runs)."""
    from analysis.io import NETCDF_SUFFIXES

    return _check_output_option(param, value, NETCDF_SUFFIXES)


def figure_output(param: typer.CallbackParam, value: Path | None) -> Path | None:
    """Option callback: ``value`` can be written as a figure (PNG, PDF, SVG, …)."""
    from analysis.io import FIGURE_SUFFIXES

    return _check_output_option(param, value, FIGURE_SUFFIXES)


def json_output(param: typer.CallbackParam, value: Path | None) -> Path | None:
    """Option callback: a JSON file can be written at ``value``."""
    return _check_output_option(param, value, (".json",))


def html_output(param: typer.CallbackParam, value: Path | None) -> Path | None:
    """Option callback: an HTML page can be written at ``value``."""
    return _check_output_option(param, value, (".html", ".htm"))


def any_output(param: typer.CallbackParam, value: Path | None) -> Path | None:
    """Option callback: a file of any kind can be written at ``value``."""
    return _check_output_option(param, value, None)


def check_out_dir(path: Path, option: str = "--out-dir") -> Path:
    """Raise ``InputError`` unless ``path`` is a folder or can be made one (its parent an
    existing, writable folder): checked before a job writes its first file."""
    import os

    if path.exists() and not path.is_dir():
        raise InputError(f"{option}: '{path}' exists and is not a folder; give a folder")
    parent = path if path.exists() else (path.parent if str(path.parent) else Path("."))
    if not parent.is_dir():
        raise InputError(f"{option}: folder '{parent}' does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"{option}: folder '{parent}' is not writable")
    return path


def frequency_words(attrs) -> str:
    """``X = 83.33 Hz, VC = 199.34 Hz`` (``VC[left] = …`` per bearing; ``F = …`` for a model
    forced at a parameter's period)."""
    from analysis.forcing import run_period_parameter
    from analysis.provenance import cage_frequencies, vc_frequencies

    words = []
    if float(attrs.get("shaft_hz", 0.0)) > 0:
        words.append(f"X = {float(attrs['shaft_hz']):.2f} Hz")
    cages = cage_frequencies(attrs)
    for bearing, vc in vc_frequencies(attrs).items():
        name = f"VC[{bearing}]" if bearing else "VC"
        cage = cages.get(bearing)
        words.append(f"{name} = {vc:.2f} Hz" + (f" (cage {cage:.2f} Hz)" if cage else ""))
    forcing = run_period_parameter(attrs)  # the forcing_period role
    if not words and forcing is not None and float(attrs[forcing]) > 0:
        words.append(f"F = 1/{forcing} = {1 / float(attrs[forcing]):.4g} Hz")
    return ", ".join(words) or "no characteristic frequency"



def write_figure(fig, output: Path | None, err: bool = False) -> None:
    if output:
        from analysis.reports.plots import save_figure

        save_figure(fig, output)
        typer.echo(f"wrote {output}", err=err)


SpeedOption = Annotated[str | None, typer.Option(
    "--speed-rpm", help="Shaft speed, rpm (simulate also takes a ramp A:B, A at t = 0 and B "
                        "at the end of the run, or a CSV speed table t_s,speed_rpm; docs: "
                        "Run-ups).")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result as JSON.")]


PERIOD_HELP = ("vc, shaft, vc:k, shaft:k, ratio:p/q (VC/X = p/q made exact), vc[BEARING] "
               "(a model with several bearings) or param:NAME (the period in s held by "
               "parameter NAME, e.g. param:forcing_period); default: the model's natural "
               "period (vc with one bearing, param:forcing_period or shaft without).")
PeriodOption = Annotated[str | None, typer.Option(help=PERIOD_HELP)]


def given_options(**options) -> dict:
    """The options the user gave (None: leave the API's default)."""
    return {k: v for k, v in options.items() if v is not None}


def orbit_structure(orbit) -> str:
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
DtOption = Annotated[float | None, typer.Option(
    "--dt", help="Largest RK4 step, s (default: the spec's).")]
SettleOption = Annotated[float | None, typer.Option(
    "--settle", help="Simulated time before the first guess, s (default: the model's own "
                     "time scale).")]
ParamOption = Annotated[str | None, typer.Option(
    "--param", help="Runtime parameter to continue in (with --from and --to).")]
FromOption = Annotated[float | None, typer.Option(
    "--from", help="Start value (parameter unit).")]
ToOption = Annotated[float | None, typer.Option("--to", help="End value (parameter unit).")]
MaxPointsOption = Annotated[int, typer.Option("--max-points", help="Points per branch.")]
DsMaxOption = Annotated[float, typer.Option(
    "--ds-max", help="Largest scaled arclength step.")]


def progress_lines(quiet: bool, err: bool = True):
    """The progress callback of ``--quiet`` (None) or one line per message (stderr)."""
    return None if quiet else (lambda text: typer.echo(text, err=err))


def as_option(exc: Exception) -> Exception:
    """``exc``, or where it is an ``InputError`` whose ``field`` is an option of the
    running command that holds a value (given or its default), the same error naming that
    option (``device gpu: …`` -> ``--device gpu: …``): the field is the error's own, no
    message text is read back. An option left empty is not named: the value came from
    elsewhere (``n_balls`` of a chart's ``--y n_balls:7:30``)."""
    field = getattr(exc, "field", None)
    context = click.globals.get_current_context(silent=True)
    if not isinstance(exc, InputError) or field is None or context is None:
        return exc
    for param in context.command.params:
        if param.name == field and param.param_type_name == "option" and \
                context.params.get(param.name) is not None:
            return exc.renamed(max(param.opts, key=len))
    return exc


def continued_systems(system, param: str | None, start: float | None, stop: float | None):
    """``(system at --from, system at --to)`` of a continuation, or ``(system, None)``
    without one: --param, --from and --to come together, the parameter exists, both ends
    are in its range and differ (each refused in one line naming the option)."""
    given = [name for name, value in (("--param", param), ("--from", start), ("--to", stop))
             if value is not None]
    if not given:
        return system, None
    if len(given) < 3:
        missing = [n for n in ("--param", "--from", "--to") if n not in given]
        raise InputError(f"{given[0]}: continuation needs --param, --from and --to; "
                         f"give {', '.join(missing)}")
    model = system.model
    if param not in model.parameter_names:
        raise InputError(f"--param: '{param}' is not a parameter of '{model.name}'; choose "
                         f"one of {', '.join(model.parameter_names)}")
    model.parameters({param: start})
    model.parameters({param: stop})
    if start == stop:
        raise InputError("--to: must differ from --from")
    return system.replace(**{param: start}), system.replace(**{param: stop})


def executor_of(kind: str, workers: int | None, scheduler: str | None):
    """The executor of ``--executor``, ``--workers`` and ``--scheduler``. A scheduler runs
    the tasks on its own workers: given with ``--workers`` or with ``--executor`` serial or
    processes typed out, it is refused (one of them would be ignored)."""
    from analysis.sweeps.executors import make_executor

    if scheduler is not None:
        context = click.globals.get_current_context(silent=True)
        typed = context is not None and context.get_parameter_source("executor") \
            == click.core.ParameterSource.COMMANDLINE
        if typed and kind != "dask":
            raise InputError(f"--scheduler: only with --executor dask (or without "
                             f"--executor), got --executor {kind}")
        if workers is not None:
            raise InputError(f"--workers: not with --scheduler (the scheduler's cluster has "
                             f"its own workers), got --workers {workers}")
    if kind == "serial" and workers is not None and workers != 1:
        raise InputError(f"--workers: --executor serial runs on one worker; give --executor "
                         f"processes or dask for {workers}, got --workers {workers}")
    return make_executor(kind, workers, scheduler)


def main(args: list[str] | None = None) -> None:
    """Run the command line (``bearingdyn``): usage errors that the parser finds before a
    command runs (``--n-balls six``, an unknown option) end in one line and exit code 2,
    with the command's ``--help`` named; ``--help`` and everything else as typer does."""
    import signal
    import sys
    import warnings

    from modelgen.errors import SpecError

    def one_line(message, category, filename, lineno, file=None, line=None):
        typer.echo(f"warning: {' '.join(str(message).split())}", err=True)

    warnings.showwarning = one_line
    if "--debug" not in (args if args is not None else sys.argv):
        sys.unraisablehook = lambda unraisable: None  # errors in finalisers: reported above
    signal.signal(signal.SIGTERM, _terminated)
    signal.signal(signal.SIGINT, _terminated)
    _state["said"] = False
    _judge_environment()
    try:
        code = app(args=args, standalone_mode=False)
    except click.exceptions.UsageError as exc:
        if exc.ctx is not None and type(exc).__name__ == "NoArgsIsHelpError":
            typer.echo(exc.ctx.get_help())  # bare `bearingdyn`: the help, as before
            sys.exit(0)
        command = exc.ctx.command_path if exc.ctx else "bearingdyn"
        typer.echo(f"error: {exc.format_message()} (see {command} --help)", err=True)
        sys.exit(2)
    except (typer.Abort, KeyboardInterrupt):
        typer.echo("interrupted", err=True)
        _leave(130)
    except BrokenPipeError:
        closed_pipe()
    except SpecError as exc:  # a spec judged while the arguments were read (_judge_spec)
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except typer.Exit as exc:
        _leave(_said(exc.exit_code))
    except Exception as exc:  # raised while the options were read: still one line
        if "--debug" in (args if args is not None else sys.argv):
            raise
        typer.echo(f"internal error: {type(exc).__name__}: {exc} (run with --debug for the "
                   "traceback)", err=True)
        sys.exit(1)
    _flush_stdout()
    _leave(_said(code if isinstance(code, int) else 0))


def _judge_environment() -> None:
    """The environment's settings (``BEARINGDYN_THREADS``) judged before any command
    starts: a bad one is one line, exit code 2."""
    import sys

    from analysis.errors import InputError
    from analysis.threads import thread_count

    try:
        thread_count()
    except InputError as exc:
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)


def _flush_stdout() -> None:
    """Flush standard output now: a reader that went away shows here (``closed_pipe``),
    not in Python's exit."""
    import sys

    try:
        sys.stdout.flush()
    except BrokenPipeError:
        closed_pipe()


def closed_pipe() -> None:
    """The reader of standard output closed it (``bearingdyn … --json | head -1``): end
    quietly with exit code 0, as the work was done; what was left unprinted goes nowhere
    (stdout pointed at the null device, so Python's final flush raises nothing)."""
    import os
    import sys

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os._exit(0)


def _said(code: int) -> int:
    """``code``, after the line ``interrupted`` for a Ctrl-C that typer turned into exit code
    130 without a word (one that came while the options were read, outside a command's
    error edge)."""
    if code == 130 and not _state["said"]:
        typer.echo("interrupted", err=True)
    return code


def _terminated(signum, frame) -> None:
    """Ctrl-C and SIGTERM: end the command (finally blocks run, the output's lock is
    released), and leave the flag ``Interrupt.requested`` for code whose library swallowed
    the exception."""
    from analysis.errors import Interrupt

    Interrupt.requested = True
    raise KeyboardInterrupt


def _leave(code: int) -> None:
    """Exit with ``code``; after an interruption or an error at once: without waiting for
    worker processes to finish their tasks (they end with this process:
    ``die_with_parent``), and without the finalisers of files left half-written by a full
    disk (HDF5 would report them again, or crash, while Python shuts down)."""
    import os
    import sys

    if code:  # after a failure, at once: no finaliser of a half-closed file runs
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
