"""Errors the user can act on. The CLI prints their message (exit code 2), no traceback."""


class BearingdynError(Exception):
    """Base class of every error bearingdyn reports to the user."""


class InputError(BearingdynError, ValueError):
    """A value given by the user is outside what the model or method allows."""


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
