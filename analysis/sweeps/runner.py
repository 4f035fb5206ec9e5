"""The one runner of a study plan (``analysis.integrate.study.StudyPlan``): its cost said,
its store opened under its key, its work on the executor, its file written atomically.

``run_study(plan, executor, …)`` is what every resumable study runs through (the chart, the
diagram, basins, fractions, global continuation, calibration) and the frequency-domain
branches (no store). The plan has checked every input already (its ``make``), so nothing
here refuses an input but the store's own: the output's folder, its lock, a stored study of
another definition. A study stopped part way (an error, Ctrl-C) keeps its stored parts and
says how to resume; one refused or failed before its first part leaves no trace
(``PointStore.stopped`` with the plan's ``total`` and ``unit``, or the plan's own
``stopped(store, exc)`` where it has one).
"""

from __future__ import annotations

from collections.abc import Callable

from analysis.integrate.study import Executor, Progress, Say, StudyPlan
from analysis.io import save_dataset
from analysis.sweeps.executors import SerialExecutor, workers_of
from analysis.sweeps.store import PointStore


def say_cost(plan: StudyPlan, executor: Executor, say: Say) -> None:
    """``plan``'s cost on ``executor``'s workers, each line to ``say``, before the work."""
    for line in plan.cost(workers_of(executor)).lines():
        say(line)


def run_study(plan: StudyPlan, executor: Executor | None = None, *,
              progress: Progress | None = None, say: Say | None = None,
              on_damaged: Callable[[str], None] | None = None, cost: bool = True):
    """Run ``plan`` (see the module): its cost to ``say`` first (not said without ``say``
    or ``cost``; ``say`` also takes the lines the plan reports as it goes), its
    parts on ``executor`` (default: serial) and in its store (a damaged stored part is
    reported to ``on_damaged(key)`` and computed again), its Dataset written to
    ``plan.output`` and returned (a plan whose ``output`` is None: run, nothing written)."""
    executor = executor or SerialExecutor()
    if say is not None and cost:
        say_cost(plan, executor, say)
    if plan.output is None:  # no file: the work alone (a calibration kept in memory)
        return plan.run(None, executor, progress, say)
    if plan.definition is None:  # no store: the work, then the file
        ds = plan.run(None, executor, progress, say)
        save_dataset(ds, plan.output)
        return ds
    store = PointStore(plan.output, dict(plan.definition), lock=True, on_damaged=on_damaged)
    try:
        ds = plan.run(store, executor, progress, say)
        save_dataset(ds, plan.output)
        store.remove()
    except BaseException as exc:  # a failure before the first part: no trace
        stopped = getattr(plan, "stopped", None)  # a plan that counts its parts itself
        if stopped is not None:
            stopped(store, exc)
        else:
            store.stopped(exc, plan.total, plan.unit)
        raise
    return ds


__all__ = ["run_study", "say_cost"]
