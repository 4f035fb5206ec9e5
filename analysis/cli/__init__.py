"""The ``bearingdyn`` command: one module per group of commands, all on one typer app.

The modules register their commands when imported, in the order ``bearingdyn --help`` lists
them: models, runs, stability, continuation, sweeps, reports. ``main`` is the console entry:
the app with command-line usage errors (a mistyped option, a value of the wrong type) cut to
one line and exit code 2, as every other bad input.
"""

# isort: off
from analysis.cli.common import app, main
from analysis.cli import models, runs, stability, continuation, sweeps, reports, curves  # noqa: F401
from analysis.cli import stiffness  # noqa: F401  (statics: static equilibrium, K and C)
from analysis.cli import explore, cite  # noqa: F401
from analysis.cli import attractors  # noqa: F401  (global dynamics: basins, attractors)
from analysis.cli import devices  # noqa: F401  (devices: cores, GPU, --device)
from analysis.cli import frequency  # noqa: F401  (harmonic balance: hb)
from analysis.cli import waterfall  # noqa: F401  (run-ups: waterfall, orders)
from analysis.cli import calibrate  # noqa: F401  (inference: calibrate)
# isort: on

__all__ = ["app", "main"]
