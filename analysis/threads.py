"""Threads of the libraries bearingdyn calls: how many BLAS threads a dense solve may use.

On a loaded machine OpenBLAS's threads spin against other processes: a 644 × 644
eigenproblem took 11 s on two threads against 0.4 s on one (measured on 2 shared cores).
The dense solves and eigenvalue problems of harmonic balance, tori and circles run inside
``blas_threads()``.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext

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
