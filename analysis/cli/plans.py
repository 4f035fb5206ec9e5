"""The one command-line path of a long computation: parse → plan → say the cost → run.

A command parses its options into the library's values, makes its study plan (every check,
once: ``analysis.integrate.study``; a refusal is one line naming the option, exit 2, before
any file or executor) and hands it to ``run_plan``, which makes the executor, says the cost
on stderr (unless ``--quiet`` or ``--json``), shows the progress and runs the plan through
the one runner (``analysis.sweeps.runner.run_study``).
"""

from __future__ import annotations

from typing import Any

import typer

from analysis.cli.common import executor_of


def recomputing(unit: str):
    """The warning for a stored part that could not be read (``point``, ``block``)."""
    def warn(key: str) -> None:
        typer.echo(f"warning: stored {unit} {key} could not be read; computing it again",
                   err=True)
    return warn


def run_plan(plan, executor: str = "serial", workers: int | None = None,
             scheduler: str | None = None, *, quiet: bool = False, label: str | None = None,
             part: str = "point", lines: bool = False,
             cost: bool = True) -> tuple[Any, str]:
    """Run ``plan`` from the command line (see the module): ``executor``, ``workers``,
    ``scheduler`` as the options give them; ``quiet``: no cost, no progress; ``label``: the
    progress bar's (default the plan's ``kind``); ``part``: what a stored part is called in
    the damaged-part warning; ``lines``: the plan reports its progress as lines (a
    continuation's values) rather than a counter; ``cost``: say the cost (``--json`` keeps
    stderr to the progress). A plan with a ``head(executor)`` method has that line said
    first (a calibration's runs and the executor). The progress starts after the cost is
    said, so its rate counts the work, not the probe. Returns the Dataset (or what a plan
    without an ``output`` returns) and the executor's name."""
    from analysis.reports.progress import ProgressReporter
    from analysis.sweeps.runner import run_study, say_cost

    say = None if quiet else (lambda text: typer.echo(text, err=True))
    ex = executor_of(executor, workers, scheduler)
    try:
        head = getattr(plan, "head", None)
        if say is not None and head is not None:
            say(head(ex))
        if say is not None and cost:
            say_cost(plan, ex, say)
        progress = None if lines else ProgressReporter(label or plan.kind, quiet,
                                                       unit=plan.unit)
        return run_study(plan, ex, progress=progress, say=say, on_damaged=recomputing(part),
                         cost=False), ex.name
    finally:
        ex.close()


__all__ = ["recomputing", "run_plan"]
