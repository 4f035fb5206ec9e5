"""One interface for running independent tasks: serially, in local processes, or on Dask.

``executor.run(fn, tasks)`` yields ``(task, result)`` pairs as tasks finish, in any order.
``fn`` must be a module-level function (it is pickled to other processes) and ``tasks``
picklable. Failed tasks are retried (``retries`` times); a worker process that dies costs a
retry of its task, not the sweep.
"""

from __future__ import annotations

import concurrent.futures as cf
import os
from collections.abc import Callable, Iterable
from typing import Any

from analysis.errors import InputError, check_count
from analysis.integrate.study import Executor

MAX_WORKERS = 1024
"""Most local worker processes."""


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
    watches the parent's pid. The worker ignores SIGINT: a Ctrl-C in the terminal reaches the
    whole process group, and the parent alone reports it (a worker idle in the pool's queue
    printed its own 20-line traceback); the workers then end with the parent."""
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)

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
            pool = cf.ProcessPoolExecutor(self.workers, initializer=die_with_parent,
                                          initargs=(os.getpid(),))
            try:
                futures = {pool.submit(fn, tasks[i]): i for i in todo}
                for future in cf.as_completed(futures):
                    i = futures[future]
                    try:
                        result = future.result()
                    except cf.process.BrokenProcessPool:  # a worker died: retry its tasks
                        broken.append(i)
                        continue
                    yield tasks[i], result
            except BaseException:  # Ctrl-C, an error, a consumer that stopped: the tasks
                # not started are dropped; the running ones end and the workers with them
                # (they hold inherited descriptors, e.g. the store's lock, until they exit)
                pool.shutdown(wait=True, cancel_futures=True)
                raise
            pool.shutdown()
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
        if scheduler is not None:
            probe_scheduler(scheduler)
            try:
                self.client = Client(scheduler, timeout=f"{3 * PROBE_SECONDS:g}s")
            except OSError as exc:
                raise InputError(f"scheduler: cannot reach {scheduler} ({exc})",
                                 field="scheduler") from None
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


PROBE_SECONDS = 3.0
"""How long the probe of a scheduler address waits to connect and for the first answer."""
SCHEDULER_SCHEMES = ("tcp", "tls")
HANDSHAKE_MOST = 1 << 20
"""Largest first message (bytes) a Dask scheduler sends: its handshake is a few hundred."""


def parse_scheduler(address: str) -> tuple[str, str, int]:
    """``tcp://host:port`` (the scheme may be left out, or be ``tls``) as (scheme, host,
    port); ``InputError`` naming what is wrong (the scheme, a missing host or port)."""
    scheme, sep, rest = address.strip().rpartition("://")
    scheme = scheme if sep else "tcp"
    allowed = f"must be tcp://HOST:PORT ({' or '.join(SCHEDULER_SCHEMES)}, port 1-65535)"
    if scheme not in SCHEDULER_SCHEMES:
        raise InputError(f"scheduler: {allowed}, got {address!r} (unknown scheme "
                         f"{scheme!r})", field="scheduler")
    host, colon, port = rest.rstrip("/").rpartition(":")
    if not colon or not port.isdigit():
        raise InputError(f"scheduler: {allowed}, got {address!r} (no port)", field="scheduler")
    host = host.removeprefix("[").removesuffix("]")
    if not host or any(c.isspace() or c in "/@" for c in host):
        raise InputError(f"scheduler: {allowed}, got {address!r} (no host)", field="scheduler")
    if not 1 <= int(port) <= 65535:
        raise InputError(f"scheduler: {allowed}, got {address!r} (port {int(port)})",
                         field="scheduler")
    return scheme, host, int(port)


def probe_scheduler(address: str, seconds: float = PROBE_SECONDS) -> None:
    """``InputError`` unless a Dask scheduler answers at ``address`` within ``seconds``:
    nothing listens there, the host is unknown or does not answer, or what answers is not
    a Dask scheduler (its first message is not a Dask handshake; Dask itself would read
    any first bytes as a length and try to allocate it)."""
    import socket
    import struct

    scheme, host, port = parse_scheduler(address)
    where = f"scheduler: {address}"
    try:
        sock = socket.create_connection((host, port), timeout=seconds)
    except socket.gaierror:
        raise InputError(f"{where}: unknown host {host!r}", field="scheduler") from None
    except TimeoutError:
        raise InputError(f"{where}: no answer within {seconds:g} s (a Dask scheduler "
                         "answers at once); is the host reachable and the address "
                         "right?", field="scheduler") from None
    except ConnectionRefusedError:
        raise InputError(f"{where}: nothing listens at {host}:{port} (connection refused); "
                         "start the scheduler (`dask scheduler`) or give its address",
                         field="scheduler") from None
    except OSError as exc:
        raise InputError(f"{where}: cannot reach {host}:{port} "
                         f"({exc.strerror or exc})", field="scheduler") from None
    with sock:
        if scheme == "tls":
            return  # the TLS handshake comes first: Dask's own connect judges it
        try:
            head = _receive(sock, 8)
            (size,) = struct.unpack("<Q", head) if len(head) == 8 else (0,)
            body = _receive(sock, size) if 0 < size <= HANDSHAKE_MOST else b""
        except OSError:  # silent within the time, or reset: no Dask handshake either way
            body = b""
    if b"pickle-protocol" not in body:
        raise InputError(f"{where}: not a Dask scheduler (what answers at {host}:{port} sent "
                         f"no Dask handshake within {seconds:g} s); give the address `dask "
                         "scheduler` prints", field="scheduler")


def _receive(sock, size: int) -> bytes:
    """Up to ``size`` bytes from ``sock`` (fewer when the peer closes)."""
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            break
        data += chunk
    return data


def make_executor(kind: str = "processes", workers: int | None = None,
                  scheduler: str | None = None) -> Executor:
    """``serial``, ``processes`` (default: all cores) or ``dask`` (``scheduler`` address,
    or a LocalCluster with ``workers`` workers)."""
    if workers is not None:
        check_count("workers", workers, 1, MAX_WORKERS)
    if scheduler is not None:
        return DaskExecutor(scheduler=scheduler)
    if kind == "serial":
        return SerialExecutor()
    if kind == "processes":
        return ProcessExecutor(workers)
    if kind == "dask":
        return DaskExecutor(workers=workers)
    raise InputError(f"executor: must be serial, processes or dask, got {kind!r}", field="executor")


def workers_of(executor: Executor) -> int:
    """How many tasks ``executor`` runs at once: 1 for the serial one, its workers for the
    others (the cores when it does not say)."""
    if isinstance(executor, SerialExecutor):
        return 1
    return int(getattr(executor, "workers", None) or os.cpu_count() or 1)


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
