"""The CPU build of the member C: the system C compiler with OpenMP, cached and locked.

The text of ``source.model_source(…, target="cpu")`` is compiled by the compiler and flags of
``analysis.integrate.compiled`` (``compiler_command``: gcc ``-O3`` without fast-math,
``-ffp-contract=off``) plus ``-fopenmp``, into the same cache (``compiled.cached_path``: named
by the SHA-256 of the source and the command), built by one process at a time (an exclusive
``flock`` on ``<library>.lock``; the others wait and load it) and renamed into place, with
its SHA-256 beside it (``compiled.intact``: a damaged file is built again, never loaded). Each
library is self-tested against CasADi when loaded (``members.self_test``): the state
variant bit for bit against the CasADi step it is written from, the tangent variant to
1e-12 against its stage RK4 in CasADi.

``run`` calls ``bd_members_<variant>(count, threads, …)``: one member per OpenMP iteration
(``schedule(dynamic, 1)``), ``threads`` cores (``BEARINGDYN_THREADS``, else every core of
``os.sched_getaffinity``).

Lanes: on a host with AVX-512F (8 doubles a vector) or AVX2 (4), both variants are built
with that instruction set (``host_lanes``, ``LANE_ISAS``: its flags join the compiler
command, so the cache key, and a host without them builds and loads its own library) and
also runs blocks of that many members at once (``source.lanes_c``), bit for bit the member by member
path (checked by ``builds.self_test``), for a model whose Functions have few libm calls
(``source.lanes_pay``); elsewhere, or when the build with them fails, they are the scalar
build.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from analysis.integrate.compiled import (
    CompileError,
    cached_path,
    compile_library,
    compiler_command,
    intact,
    library_stem,
)
from analysis.threads import thread_count

OPENMP_FLAG = "-fopenmp"
"""The compiler flag of OpenMP (gcc and clang)."""
LANE_ISAS = ((8, "avx512f", ("-mavx512f", "-mprefer-vector-width=512")),
             (4, "avx2", ("-mavx2",)))
"""Members per block of lanes, the /proc/cpuinfo flag of the instruction set and its
compiler flags, best first (doubles of 512 and 256 bits). Without either the lanes lose
(2 doubles of SSE2: 0.8 times the scalar stage), so the build stays scalar."""


@cache
def host_isas() -> dict[int, tuple[str, ...]]:
    """The compiler flags of every entry of ``LANE_ISAS`` whose flag the kernel lists in
    /proc/cpuinfo, by members per block of lanes, best first (none without that file)."""
    try:
        with open("/proc/cpuinfo") as handle:
            line = next((x for x in handle if x.startswith("flags")), "")
    except OSError:
        return {}
    flags = set(line.split(":", 1)[-1].split())
    return {lanes: options for lanes, flag, options in LANE_ISAS if flag in flags}


def host_lanes() -> tuple[int, tuple[str, ...]]:
    """The members per block of lanes on this host and their compiler flags: the best of
    ``host_isas``, or ``(0, ())`` (scalar)."""
    return next(iter(host_isas().items()), (0, ()))


def cores() -> int:
    """CPU cores this process may use: ``analysis.threads.thread_count`` (the variable
    ``BEARINGDYN_THREADS``, checked, else every core of the affinity mask)."""
    return thread_count()


@contextmanager
def compiling(path: Path) -> Iterator[None]:
    """Holds an exclusive lock on ``<path>.lock`` (POSIX ``flock``; nothing elsewhere):
    processes that first meet a model and balls at the same moment compile its library
    once, the others wait and load it."""
    try:
        import fcntl
    except ImportError:  # no flock: each process may compile (renamed atomically anyway)
        yield
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_suffix(".lock"), "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@dataclass
class CpuLibrary:
    """A loaded CPU build: ``fn`` is ``bd_members_<variant>``."""

    path: Path
    fn: Any
    lanes: int = 0
    """Members per block of lanes (0: none)."""

    def run(self, count: int, threads: int, inputs: list[np.ndarray], kmax: int, keep: bool,
            outputs: list[np.ndarray]) -> None:
        """One call over ``count`` members on ``threads`` cores. ``inputs``: the per-member
        arrays of ``source._ARGS`` in order (z0, k0, p, h, t0, limit as float64; transient,
        every, n_sec, skip as int64), ``outputs``: sections, logs, final, diverged (int64),
        low, high; all C-contiguous."""
        ptr = [a.ctypes.data_as(ctypes.c_void_p) for a in (*inputs, *outputs)]
        self.fn(ctypes.c_longlong(count), ctypes.c_int(threads), *ptr[:len(inputs)],
                ctypes.c_longlong(kmax), ctypes.c_int(int(keep)), *ptr[len(inputs):])


def build(source: str, stem: str, symbol: str, extra: tuple[str, ...] = ()) -> CpuLibrary:
    """The library of ``source`` from the cache (built there once, by one process at a
    time, with ``extra`` compiler flags after the others) and its function ``symbol``;
    ``CompileError`` when it cannot be built or loaded."""
    command = [*compiler_command(), OPENMP_FLAG, *extra]
    path = cached_path(stem, source, command)
    # idle threads sleep instead of spinning (read by libgomp when it loads): a chart's
    # worker processes may share the cores, and a call's end waits for its longest member
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    try:
        if not intact(path):  # missing, or damaged: never loaded (it could kill us: SIGBUS)
            with compiling(path):  # a second process waits, then loads the first's build
                if not intact(path):
                    compile_library(source, path, command)
        fn = getattr(ctypes.CDLL(str(path)), symbol)
    except (OSError, AttributeError) as exc:
        raise CompileError(f"could not load {path.name}: {exc}") from None
    fn.restype = None
    return CpuLibrary(path, fn)


@cache
def cpu_library(model: Any, structure: tuple[int, ...], tangent: bool,
                lanes: int | None = None, symbol: str = "") -> CpuLibrary:
    """The CPU build of ``model``'s member C with these balls (the tangent variant with
    ``tangent``), memoised per process; ``CompileError`` or ``source.Unsupported`` when it
    cannot be written or built. ``lanes``: members per block of lanes (None:
    ``host_lanes`` where they pay, ``source.lanes_pay``, scalar when that build fails; 0:
    scalar; 4 or 8: with the flags of ``host_isas``, portable vector C on a host without
    them, for tests); ``symbol``: a suffix of the function (``"_lanes"`` or
    ``"_single"``: one path of a build with lanes)."""
    from analysis.integrate.kernels.source import lanes_pay, model_source

    variant = "tangent" if tangent else "states"
    stem = library_stem(f"bd_members_{variant}", model, structure)

    def built(lanes: int, flags: tuple[str, ...]) -> CpuLibrary:
        lib = build(model_source(model, structure, tangent, "cpu", lanes), stem,
                    f"bd_members_{variant}{symbol}", flags)
        lib.lanes = lanes
        return lib

    if lanes is None:
        host, isa = host_lanes()
        if host and lanes_pay(model, structure, tangent):
            try:
                return built(host, isa)
            except CompileError:  # a compiler without the instruction set: scalar
                pass
        lanes = 0
    if symbol and not lanes:
        raise ValueError(f"symbol {symbol!r}: only in a build with lanes")
    return built(lanes, host_isas().get(lanes, ()) if lanes else ())
