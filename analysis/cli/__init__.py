"""The ``bearingdyn`` command: one module per group of commands, all on one typer app.

The modules register their commands when first needed (``main``, or ``analysis.cli.app``),
in the order ``bearingdyn --help`` lists them: models, runs, stability, continuation, sweeps,
reports. ``main`` runs the app with command-line usage errors (a mistyped option, a value
of the wrong type) cut to one line and exit code 2, as every other bad input. The console
script is ``analysis.cli.entry``, whose first statement installs a Ctrl-C handler;
``import analysis.cli`` itself loads nothing heavy, so a Ctrl-C while the commands are still
loading (the first fraction of a second) ends as every other one does: the line
``interrupted`` and exit code 130, never a traceback.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["app", "main"]


def _register() -> Any:
    """Import every command module (each adds its commands to the app); return the app."""
    # isort: off
    from analysis.cli.common import app
    from analysis.cli import models, runs, stability, continuation, sweeps, reports, curves  # noqa: F401
    from analysis.cli import stiffness  # noqa: F401  (statics: static equilibrium, K and C)
    from analysis.cli import explore, cite  # noqa: F401
    from analysis.cli import attractors  # noqa: F401  (global dynamics: basins, attractors)
    from analysis.cli import devices  # noqa: F401  (devices: cores, GPU, --device)
    from analysis.cli import frequency  # noqa: F401  (harmonic balance: hb)
    from analysis.cli import waterfall  # noqa: F401  (run-ups: waterfall, orders)
    from analysis.cli import calibrate  # noqa: F401  (inference: calibrate)
    from analysis.cli import records  # noqa: F401  (measured records: record info)
    from analysis.cli import diagnose  # noqa: F401  (measured records: bearing diagnosis)
    from analysis.cli import compare  # noqa: F401  (model against measurement)
    from analysis.cli import uncertainty  # noqa: F401  (regimes under tolerances)
    from analysis.cli import linear, import_ross  # noqa: F401  (campbell, unbalance, import-ross)
    # isort: on
    return app


def main(args: list[str] | None = None) -> None:
    """Run the ``bearingdyn`` command line (see ``analysis.cli.common.main``)."""
    try:
        _register()
        from analysis.cli.common import main as run
    except KeyboardInterrupt:  # Ctrl-C while the commands load: nothing was started
        if "--debug" in (args if args is not None else sys.argv):
            raise
        sys.stderr.write("interrupted (nothing was started)\n")
        sys.stderr.flush()
        raise SystemExit(130) from None
    run(args)


def __getattr__(name: str) -> Any:
    if name == "app":
        return _register()
    raise AttributeError(f"module 'analysis.cli' has no attribute {name!r}")
