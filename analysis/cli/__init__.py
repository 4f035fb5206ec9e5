"""The ``bearingdyn`` command: one module per group of commands, all on one typer app.

The modules register their commands when imported, in the order ``bearingdyn --help`` lists
them: models, runs, stability, continuation, sweeps, reports.
"""

# isort: off
from analysis.cli.common import app
from analysis.cli import models, runs, stability, continuation, sweeps, reports, curves  # noqa: F401
from analysis.cli import explore, cite  # noqa: F401
# isort: on

__all__ = ["app"]
