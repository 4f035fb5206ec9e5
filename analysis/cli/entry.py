"""The ``bearingdyn`` console script (and ``python -m analysis.cli``): its first statement
installs a Ctrl-C handler, before anything of the command is imported.

A Ctrl-C while Python loads the command's modules (the first few tenths of a second: typer and
the command modules) then ends as every other interrupt does: the line ``interrupted
(nothing was started)`` and exit code 130, never a ``KeyboardInterrupt`` traceback. Once
the command line is read, ``analysis.cli.common.main`` installs its own handler (finally
blocks run, outputs are left whole). What remains is the interpreter's own start before
this module runs (about 20–40 ms: Python's initialisation, ``site`` and its ``.pth`` files,
and the two package ``__init__`` files, which import only the standard library's
``importlib`` and ``typing``): a Ctrl-C there is Python's (docs/bad-inputs.md).

``bearingdyn --debug`` keeps Python's own handling (a traceback on Ctrl-C).
"""

import signal  # first: the handler before any other import
import sys


def _interrupted_while_starting(signum, frame) -> None:
    """SIGINT before the command runs: one line, exit code 130, nothing to clean up."""
    import os

    try:
        os.write(2, b"interrupted (nothing was started)\n")
    finally:
        os._exit(130)


if "--debug" not in sys.argv:
    signal.signal(signal.SIGINT, _interrupted_while_starting)


def main() -> None:
    """Run the ``bearingdyn`` command line (``analysis.cli.main``)."""
    from analysis.cli import main as run

    run()
