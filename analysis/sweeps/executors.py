"""One interface for running independent tasks: serially, in local processes, or on Dask.

``executor.run(fn, tasks)`` yields ``(task, result)`` pairs as tasks finish, in any order.
``fn`` must be a module-level function (it is pickled to other processes) and ``tasks``
picklable. Failed tasks are retried (``retries`` times); a worker process that dies costs a
retry of its task, not the sweep.
"""

from __future__ import annotations

import concurrent.futures as cf
import os
from collections.abc import Callable, Iterable, Iterator
from typing import Any, Protocol

from analysis.errors import InputError

MAX_WORKERS = 1024
"""Most local worker processes."""


class Executor(Protocol):
    name: str

    def run(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[tuple[Any, Any]]:
        """Yield (task, fn(task)) as tasks complete."""

    def close(self) -> None: ...


class SerialExecutor:
    """Runs tasks one after the other in this process."""

    name = "serial"

    def run(self, fn, tasks):
        for task in tasks:
            yield task, fn(task)

    def close(self) -> None:
        pass


def die_with_parent(parent: int) -> None:
    """Worker initializer: end this process when its parent ends, however it ends (SIGTERM,
    SIGKILL, a crash). Linux: ``prctl(PR_SET_PDEATHSIG, SIGKILL)``; elsewhere a thread that
    watches the parent's pid."""
    import signal
    import sys

    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    else:  # pragma: no cover
        import threading
        import time

        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(1.0)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()
    if os.getppid() != parent:  # the parent ended before the flag was set
        os._exit(1)


class ProcessExecutor:
    """Local worker processes (``concurrent.futures``); a broken pool is rebuilt and the
    unfinished tasks resubmitted (up to ``retries`` times each). Workers end with the
    process that started them (``die_with_parent``)."""

    def __init__(self, workers: int | None = None, retries: int = 2):
        self.workers = workers or os.cpu_count() or 1
        self.retries = retries
        self.name = f"processes ({self.workers})"

    def run(self, fn, tasks):
        tasks = list(tasks)
        todo, attempts = list(range(len(tasks))), [0] * len(tasks)
        while todo:
            broken = []
            with cf.ProcessPoolExecutor(self.workers, initializer=die_with_parent,
                                        initargs=(os.getpid(),)) as pool:
                futures = {pool.submit(fn, tasks[i]): i for i in todo}
                for future in cf.as_completed(futures):
                    i = futures[future]
                    try:
                        result = future.result()
                    except cf.process.BrokenProcessPool:  # a worker died: retry its tasks
                        broken.append(i)
                        continue
                    yield tasks[i], result
            for i in broken:
                attempts[i] += 1
                if attempts[i] > self.retries:
                    raise RuntimeError(f"task {tasks[i]!r} lost its worker "
                                       f"{attempts[i]} times")
            todo = broken

    def close(self) -> None:
        pass


class DaskExecutor:
    """A Dask distributed cluster: an existing scheduler (``tcp://host:port``) or a
    ``LocalCluster`` started here with ``workers`` single-threaded worker processes."""

    def __init__(self, scheduler: str | None = None, workers: int | None = None,
                 retries: int = 2):
        from distributed import Client, LocalCluster

        self.retries = retries
        self.cluster = None
        if scheduler:
            try:
                self.client = Client(scheduler, timeout="20s")
            except OSError as exc:
                raise InputError(f"--scheduler: cannot reach {scheduler} ({exc})") from None
            self.name = f"dask {scheduler}"
        else:
            n = workers or os.cpu_count() or 1
            self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                        host="127.0.0.1", dashboard_address=None)
            self.client = Client(self.cluster)
            self.name = f"dask LocalCluster ({n} workers)"

    def run(self, fn, tasks):
        from distributed import as_completed

        tasks = list(tasks)
        futures = {self.client.submit(fn, task, retries=self.retries, pure=False): i
                   for i, task in enumerate(tasks)}
        for future in as_completed(futures):
            yield tasks[futures[future]], future.result()

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def make_executor(kind: str = "processes", workers: int | None = None,
                  scheduler: str | None = None) -> Executor:
    """``serial``, ``processes`` (default: all cores) or ``dask`` (``scheduler`` address,
    or a LocalCluster with ``workers`` workers)."""
    if workers is not None and not (isinstance(workers, int) and 1 <= workers <= MAX_WORKERS):
        raise InputError(f"--workers: must be a whole number in [1, {MAX_WORKERS}], "
                         f"got {workers}")
    if scheduler:
        return DaskExecutor(scheduler=scheduler)
    if kind == "serial":
        return SerialExecutor()
    if kind == "processes":
        return ProcessExecutor(workers)
    if kind == "dask":
        return DaskExecutor(workers=workers)
    raise InputError(f"--executor: must be serial, processes or dask, got {kind!r}")


def run_with_progress(executor: Executor, fn: Callable[[Any], Any], tasks: Iterable[Any],
                      done: Callable[[], int], total: int,
                      progress: Callable[[int, int], None] | None,
                      on_result: Callable[[Any, Any], None] | None) -> None:
    """Run ``tasks`` on ``executor`` in a background thread, handing each (task, result) to
    ``on_result``; report ``progress(done(), total)`` meanwhile (``done``: the number of
    stored points)."""
    import threading

    failure: list[BaseException] = []

    def consume():
        try:
            for task, result in executor.run(fn, tasks):
                if on_result:
                    on_result(task, result)
        except BaseException as exc:  # re-raised in the calling thread
            failure.append(exc)

    worker = threading.Thread(target=consume, daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.5)
        if progress:
            progress(done(), total)
    if failure:
        raise failure[0]
    if progress:
        progress(done(), total)
