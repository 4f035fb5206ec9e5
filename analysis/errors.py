"""Errors the user can act on. The CLI prints their message (exit code 2), no traceback."""

from __future__ import annotations

from collections.abc import Mapping


class BearingdynError(Exception):
    """Base class of every error bearingdyn reports to the user."""


class InputError(BearingdynError, ValueError):
    """A value given by the user is outside what the model or method allows.

    ``field``: the parameter the message names first (``"harmonics"``), when the raiser
    says so; the message then begins ``"<field>: "``, or ``"<field> <item>: "`` where it
    is about one item of the parameter (``"prior damping: "``). The command line shows the
    option of that parameter instead (``--harmonics: …``, ``--prior damping: …``) without
    reading the message text back."""

    field: str | None = None

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        if field is not None:
            if not message.startswith((f"{field}:", f"{field} ")):
                raise ValueError(f"an InputError naming field {field!r} must begin with it: "
                                 f"{message!r}")
            self.field = field

    def __reduce__(self):  # pickled across worker processes with its field
        return (type(self), (str(self), self.field))

    def renamed(self, name: str) -> InputError:
        """The same error naming ``name`` (an option, ``--harmonics``) instead of its
        field."""
        assert self.field is not None
        return InputError(name + str(self)[len(self.field):])


class ParameterError(InputError):
    """An ``InputError`` about the parameter ``field`` whose line says more than its head:
    ``template`` holds ``{field}`` wherever the parameter is named and ``{word}`` for each
    of ``words`` (``word -> (the library's words, the command line's words)``), for a line
    that names other parameters too. The library's line names parameters
    (``sets speed_rpm: also an axis; …``); ``renamed(option)``, the command line's edge
    (``cli.common.as_option``), gives the same line with the field's option and the
    command line's words (``--set speed_rpm: …; drop the --set …``): no text is read back.

    >>> err = ParameterError("ics_box", "{field}: draws the states of {ics}",
    ...                      {"ics": ("ics", "--ics")})
    >>> str(err), str(err.renamed("--ics-box"))
    ('ics_box: draws the states of ics', '--ics-box: draws the states of --ics')
    """

    def __init__(self, field: str, template: str,
                 words: Mapping[str, tuple[str, str]] | None = None) -> None:
        self.field, self.template, self.words = field, template, dict(words or {})
        super().__init__(self.text(field))

    def text(self, name: str, command_line: bool = False) -> str:
        """The line naming the parameter ``name`` (the field or its option), with the
        command line's words where ``command_line``."""
        return self.template.format(field=name, **{k: v[int(command_line)]
                                                   for k, v in self.words.items()})

    def renamed(self, name: str) -> InputError:
        return InputError(self.text(name, command_line=True))

    def __reduce__(self):  # pickled across worker processes with its parts
        return type(self), (self.field, self.template, self.words)


class StaleModelError(BearingdynError):
    """A generated model does not match its spec any more."""


class SimulationError(BearingdynError):
    """A numerical run failed (blow-up, solver failure)."""


class WriteError(BearingdynError):
    """A result could not be written (full disk, quota, I/O error); nothing was replaced."""


class Interrupt:
    """Ctrl-C and SIGTERM as a flag as well as an exception: the command line's handler sets
    ``requested`` and raises ``KeyboardInterrupt``; code that calls into libraries which may
    swallow that exception (HDF5's writers) calls ``check()`` at its own safe points, so an
    interruption is never lost."""

    requested = False

    @classmethod
    def check(cls) -> None:
        """Raise ``KeyboardInterrupt`` when an interruption was requested."""
        if cls.requested:
            raise KeyboardInterrupt


def check_count(field: str, value: object, low: int = 1, high: int | None = None,
                note: str = "", *, text: bool = False) -> int:
    """``value`` as an ``int`` when it is a whole number in [``low``, ``high``] (no upper
    bound without ``high``); ``InputError`` naming ``field`` otherwise: the one check of
    every count (harmonics, points, balls, samples, workers, blocks). ``text``: a string of
    digits (``"8"``, from a command line or a list ``"8,4"``) is read as its number; ``note``
    is said after the range. ``bool`` is not a count, nor is 8.0.

    >>> check_count("points", 33, 8)
    33
    >>> check_count("points", "33", 8, text=True)
    33
    >>> check_count("workers", 0, 1, 64)
    Traceback (most recent call last):
    ...
    analysis.errors.InputError: workers: must be a whole number in [1, 64], got 0
    """
    number = value
    if text and isinstance(value, str):
        try:
            number = int(value.strip())
        except ValueError:
            number = None
    whole = not isinstance(number, bool) and hasattr(number, "__index__")
    if not whole or number < low or (high is not None and number > high):
        bounds = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise InputError(f"{field}: must be a whole number {bounds}{note}, got {value!r}",
                         field=field)
    return int(number)
