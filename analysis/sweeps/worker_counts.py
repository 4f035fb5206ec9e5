"""How far the tasks on an executor are, within each task: ``WorkerCounts``, a small file
of one count per task written by the workers and read by the parent, so a progress counter
moves while a task runs (attractor blocks, calibration rounds), not once per task."""

from __future__ import annotations

import os
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

Progress = Callable[[int, int], None]
"""``progress(done, total)``: members done so far of ``total``."""


class WorkerCounts:
    """How far the tasks on an executor are: one int64 per task (its members done so far) in
    a small file (``.progress.*.tmp`` in ``folder``, a store's folder, where one left by a
    killed run is removed with the store's other temporaries; None: the temporary folder),
    written by the task (``writer``, in a worker or in this process), read by the parent
    (``count``), so a counter moves within a task, not once per task. A worker that cannot
    open the file (a Dask worker on another machine) writes nothing: its task then counts
    once it is done. Use as a context manager (the file is removed on exit); the parent
    updates its own count of finished members and calls ``finish(slot)`` under ``lock``."""

    def __init__(self, folder: Path | str | None, tasks: int, total: int):
        fd, self.path = tempfile.mkstemp(prefix=".progress.", suffix=".tmp",
                                         dir=os.path.abspath(folder) if folder else None)
        os.ftruncate(fd, 8 * tasks)
        os.close(fd)
        self.finished = np.zeros(tasks, dtype=bool)
        self.total, self.shown = total, 0
        self.lock = threading.Lock()

    def __enter__(self) -> WorkerCounts:
        return self

    def __exit__(self, *exc: object) -> None:
        Path(self.path).unlink(missing_ok=True)

    def where(self, slot: int) -> tuple[str, int]:
        """What a task needs to write its count (``writer``'s arguments)."""
        return self.path, slot

    def finish(self, slot: int) -> None:
        """Task ``slot`` is done (its members now counted by the parent; hold ``lock``)."""
        self.finished[slot] = True

    def running(self) -> int:
        """Members done in the tasks not yet finished."""
        try:
            counts = np.fromfile(self.path, dtype=np.int64)
        except OSError:
            return 0
        return int(counts[~self.finished[:len(counts)]].sum())

    def count(self, finished: Callable[[], int]) -> int:
        """``finished()`` (the parent's count of the finished tasks' members) plus the
        running tasks' counts: monotone (a retried task starts its slot again), at most
        ``total``."""
        with self.lock:
            self.shown = max(self.shown, min(finished() + self.running(), self.total))
            return self.shown

    @staticmethod
    def writer(path: str, slot: int) -> Progress:
        """A worker's ``progress(done, total)`` writing ``done`` to ``slot`` of ``path``."""
        def write(done: int, _: int) -> None:
            try:
                fd = os.open(path, os.O_WRONLY)
            except OSError:  # not on this machine, or the run is over
                return
            try:
                os.pwrite(fd, np.int64(done).tobytes(), 8 * slot)
            finally:
                os.close(fd)

        return write
