"""A study plan: one long computation, every input checked once, before any work.

A long computation (a stability chart, a brute-force diagram, basins, basin fractions, a
global continuation, a calibration, a frequency-domain branch) is made in two steps:

1. **plan**: a ``make`` (``plan_chart``, ``plan_basins`` …) runs every check of the study
   once (inputs, grid, step, memory, the device judged once: ``kernels.placement.place``)
   and returns a frozen plan that holds what it checked. A refusal is an ``InputError``
   naming its field; nothing has been written and no executor started;
2. **run**: the one runner (``analysis.sweeps.runner.run_study``) says the plan's cost,
   opens the plan's store under its key (``definition``: what makes its stored parts, so an
   interrupted study resumes and a study of other settings is refused), hands it and the
   executor to ``plan.run``, writes the file atomically and removes the store.

A plan is a ``StudyPlan``: the protocol below. Plans are data (frozen dataclasses) and do
not know the command line; the CLI path is ``analysis.cli.plans.run_plan``: parse → plan →
say the cost → run. "Adding a study" in docs/architecture.md shows a new one, run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import xarray as xr

    from analysis.integrate.cost import CostEstimate
    from analysis.integrate.kernels.placement import Placement

Progress = Callable[[int, int], None]
"""``progress(done, total)``: units of a study done so far, of ``total``."""
Say = Callable[[str], None]
"""A line for the user (stderr on the command line): the cost, a continuation's values."""


class Executor(Protocol):
    """Where a study's independent tasks run (``analysis.sweeps.executors``: serial, local
    processes or Dask)."""

    name: str

    def run(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[tuple[Any, Any]]:
        """Yield (task, fn(task)) as tasks complete."""

    def close(self) -> None: ...


class Store(Protocol):
    """What a plan's ``run`` uses of its store (``analysis.sweeps.store.PointStore``): the
    keys of its stored parts, each written atomically, read back."""

    folder: Path

    def done(self) -> set[str]: ...

    def save(self, key: str, values: dict[str, Any]) -> None: ...

    def load(self, key: str) -> dict[str, Any]: ...


@runtime_checkable
class StudyPlan(Protocol):
    """A long computation, checked whole (see the module).

    - ``kind``: its name (the store's ``kind``, the progress bar's label);
    - ``unit``: what ``total`` and its progress count (``points``, ``initial states``,
      ``runs``);
    - ``output``: the netCDF file it writes (None: nothing is written, the run's value is
      returned: a calibration kept in memory);
    - ``definition``: its store key (JSON-like: what makes its stored parts), or None for a
      study that keeps no store (it is not resumable: a frequency-domain branch);
    - ``placement``: where its members run (judged once by ``make``), or None where no
      member kernel runs;
    - ``total``: units of work;
    - ``cost(workers)``: its cost on ``workers`` workers, said before the work (a timed
      probe of what will run: ``analysis.integrate.cost``);
    - ``run(store, executor, progress, say)``: the work, its parts stored in ``store`` (None
      when ``definition`` is None) as they finish; returns the Dataset the runner writes.

    Two methods are optional (the runner and the CLI path use them where a plan has them):
    ``head(executor) -> str``, a line said before the cost (a calibration's runs and the
    executor), and ``stopped(store, exc)``, the note of a study stopped part way where it
    counts its stored parts in its own words (blocks of initial states).
    """

    kind: str
    unit: str
    output: Path | None
    definition: Mapping[str, Any] | None
    placement: Placement | None
    total: int

    def cost(self, workers: int) -> CostEstimate: ...

    def run(self, store: Store | None, executor: Executor, progress: Progress | None,
            say: Say | None) -> xr.Dataset: ...


__all__ = ["Executor", "Progress", "Say", "Store", "StudyPlan"]
