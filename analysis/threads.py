"""Threads: how many cores the member kernels may use (``BEARINGDYN_THREADS``), and how
many BLAS threads a dense solve may use.

On a loaded machine OpenBLAS's threads spin against other processes: a 644 × 644
eigenproblem took 11 s on two threads against 0.4 s on one (measured on 2 shared cores).
The dense solves and eigenvalue problems of harmonic balance, tori and circles run inside
``blas_threads()``.
"""

from __future__ import annotations

import os
from contextlib import AbstractContextManager, nullcontext

THREADS_VARIABLE = "BEARINGDYN_THREADS"
"""Environment variable: CPU cores the member kernels use (default: every core available)."""


def available_cores() -> int:
    """CPU cores this process may run on: the affinity mask's size
    (``os.sched_getaffinity``), else ``os.cpu_count()``."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def thread_count() -> int:
    """CPU cores this process may use: ``BEARINGDYN_THREADS`` when set, else every core it
    may run on. A value that is not a whole number in [1, available cores] is an
    ``InputError`` naming the variable (it was silently ignored, and 100000 was reported as
    100000 cores). The command line checks it before any command starts."""
    from analysis.errors import InputError, check_count

    given = os.environ.get(THREADS_VARIABLE, "").strip()
    available = available_cores()
    if not given:
        return available
    try:
        return check_count(THREADS_VARIABLE, given, 1, available,
                           " (the cores this process may use)", text=True)
    except InputError as err:
        raise InputError(f"{err}; unset it to use every core") from None

BLAS_THREADS = 1
"""BLAS threads of the dense solves and eigenvalue problems (``blas_threads``)."""


def blas_threads(limit: int | None = None) -> AbstractContextManager:
    """A context with at most ``limit`` BLAS threads (default ``BLAS_THREADS``), by
    threadpoolctl when installed (else nothing changes).

    >>> with blas_threads():
    ...     pass
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover
        return nullcontext()
    return threadpool_limits(limits=BLAS_THREADS if limit is None else limit,
                             user_api="blas")
