"""``run_members``: M members of one model and balls through the member kernels.

Each member has its own initial state, parameter vector, step h (s), start time t0 (s) and
step counter k0 (step k runs from ``t0 + k·h``), and follows one ``Schedule``: a transient of
whole RK4 steps, then K sections every ``steps_per_section`` steps, recorded (or only reduced:
the final state, the blow-up step, the extremes, the tangent's λ1). Members run in blocks
(``block`` members per call; memory on the device is bounded by the block), on the CPU build
(``cpu.py``, every core) or the CUDA build (``cuda.py``), from one C text (``source.py``).
A member whose state is not finite or whose centre displacement leaves its blow-up limit
(``simulate.blow_up_limit``, the predicate of ``simulate.bad_states``) stops there: its
``diverged_at`` is that step, its later sections and logs NaN; its neighbours are unaffected.

With ``features`` a run on the GPU reduces each member's sections on the device
(``section_features``: the mean and the extent, max − min, of every state over the K
sections, 2n numbers) and copies back only those, not the K × n section points (with the
final state, the blow-up step and the extremes, as always): 8 · 2n bytes of sections' worth
per member instead of 8 · K · n. A member's run does not depend on the other members of
its call, so the sections of a few members are had again, exactly, by running those
members alone.

The state variant on the CPU is the compiled path's RK4 (``simulate``, ``ensemble``) bit for
bit; the CUDA build agrees with it to the last bits of CUDA's libm.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from analysis.budgets import RUN_MEMORY
from analysis.errors import InputError, SimulationError, check_count
from analysis.integrate.kernels.builds import GPU_SELF_TEST_TOL as GPU_SELF_TEST_TOL
from analysis.integrate.kernels.builds import SELF_TEST_TOL as SELF_TEST_TOL
from analysis.integrate.kernels.builds import (
    cpu_kernel,
    gpu_kernel,
    self_test,
    self_test_gpu,
)
from analysis.integrate.kernels.builds import unbuildable as unbuildable
from analysis.integrate.kernels.cpu import cores
from analysis.integrate.kernels.placement import CPU, Placement, on_gpu, place
from analysis.integrate.kernels.schedule import Schedule
from analysis.integrate.simulate import blow_up_limit, check_bounded
from analysis.model import System

_self_test, _self_test_gpu = self_test, self_test_gpu
"""The self-tests (``builds``), under the names whose caches tests and benchmarks clear."""
CPU_BLOCK = 1 << 16
"""Members per call of the CPU build by default (progress is reported per call)."""
PROGRESS_SECONDS = 0.5
"""With a ``progress`` callback and no ``block`` on the CPU: the members of a call run in
sub-chunks of about this much work each, so the counter moves every half second or so
(each member runs alone: the results are those of one call, bit for bit)."""
CHUNK_PER_THREAD = 4
"""Least members per thread in such a sub-chunk (OpenMP still fills every core)."""
GPU_BLOCK_SHARE = 0.5
"""Share of the GPU's free memory one block of members may take."""


def section_features(xp, sections):
    """(M, 2n) the sections (M, K, n; SI units) of each member reduced over K: the mean
    (the sum in section order, divided by K) and the extent (max − min) of every state,
    NaN where a section is NaN. ``xp``: ``numpy`` for host arrays, ``cupy`` for device
    arrays (``cuda.CudaKernel.run``), the same operations in the same order, so a device's
    reduction equals the host's bit for bit (IEEE sums and quotients; no (M, K, n)
    temporaries: one section at a time)."""
    first = sections[:, 0]
    low, high, total = first.copy(), first.copy(), first.copy()
    for k in range(1, sections.shape[1]):
        point = sections[:, k]
        xp.minimum(low, point, out=low)
        xp.maximum(high, point, out=high)
        total += point
    return xp.concatenate([total / sections.shape[1], high - low], axis=1)


def section_step(period_s: float, dt: float) -> tuple[float, int]:
    """(h, N): the largest RK4 step h <= ``dt`` (s) that divides the section period
    ``period_s`` (s) into N whole steps, N = ceil(T/dt − 1e-9), h = T/N: sections then fall
    on steps (no interpolation between samples). A period of whole steps of ``dt`` (to
    1e-9 of a step) keeps h = ``dt`` exactly."""
    if not (math.isfinite(period_s) and period_s > 0):
        raise InputError(f"period_s: a finite period > 0 s, got {period_s!r}")
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"dt: a finite step > 0 s, got {dt!r}")
    steps = max(1, math.ceil(period_s / dt - 1e-9))
    if abs(period_s / dt - steps) <= 1e-9:  # already whole steps: keep dt itself (bit for
        return float(dt), steps             # bit the run of h = dt; T/N may round off it)
    return period_s / steps, steps


@dataclass
class MemberResult:
    """What ``run_members`` returns (SI units; M members, K sections, n states)."""

    sections: np.ndarray | None
    """(M, K, n) states at the K sections, NaN after a blow-up (None: ``keep_sections``
    False)."""
    logs: np.ndarray | None
    """(M, K) log growth of the tangent over each section interval (None without the
    tangent); NaN after a blow-up."""
    lambda1: np.ndarray | None
    """(M,) 1/s: mean of the logs after ``lyapunov_skip`` divided by the section interval
    (``steps_per_section · h``); None without the tangent, NaN after a blow-up."""
    diverged_at: np.ndarray
    """(M,) int64: the step counter k of the first state beyond the blow-up bound (its time
    is ``t0 + k·h``), -1 if never."""
    final: np.ndarray
    """(M, n) the last state (after the last step, or the first bad state)."""
    low: np.ndarray
    """(M, n) smallest value of every state over the steps ``Schedule.extremes_from`` …
    ``extremes_to`` (default: from the end of the skipped sections to the last section;
    up to a blow-up)."""
    high: np.ndarray
    """(M, n) largest value, likewise."""
    device: str
    """``"cpu"`` or ``"gpu"`` (``Placement.kind``)."""
    features: np.ndarray | None = None
    """(M, 2n) ``section_features`` of the sections (mean, then max − min, per state; SI
    units), when ``run_members`` was asked for them (None otherwise); NaN after a
    blow-up."""


def _per_member(name: str, value: np.ndarray | float, m: int, positive: bool) -> np.ndarray:
    out = np.asarray(value, dtype=float)
    if out.ndim == 0:
        out = np.full(m, float(out))
    if out.shape != (m,):
        raise InputError(f"{name}: one number or one per member ({m}), got shape {out.shape}")
    if not np.all(np.isfinite(out)) or (positive and np.any(out <= 0)):
        raise InputError(f"{name}: finite{' and > 0' if positive else ''} values, got "
                         f"{out[~np.isfinite(out) | (out <= 0 if positive else False)][0]!r}")
    return np.ascontiguousarray(out)


def _bytes_per_member(schedule: Schedule, n: int, n_par: int, reduced: bool = False) -> int:
    """Bytes of one member's inputs and outputs in a call (``reduced``: its sections as
    the 2n features, as they reach the host from a device reduction)."""
    k = schedule.max_sections
    kept = (2 * n if reduced else k * n) if schedule.keep_sections else 0
    return 8 * (n + 1 + n_par + 3 + kept + (k if schedule.tangent else 0) + 3 * n + 1)


def check_fits(device: str | Placement, members: int, schedule: Schedule, n: int,
               n_par: int = 0, features: bool = False) -> None:
    """``InputError`` before anything is allocated when the results of ``members``
    members do not fit the host's budget (``RUN_MEMORY``; the device streams blocks, so
    only the kept results count), or when one member does not fit the GPU's free memory
    (``device``: a ``Placement``, or a resolved name ``"cpu"`` or ``"gpu"``). ``features``:
    the run asks for ``run_members``'s ``features``, so a GPU's results reach the host as
    2n features per member (its sections still live on the device)."""
    per = _bytes_per_member(schedule, n, n_par)
    kept = members * _bytes_per_member(schedule, n, n_par, features and on_gpu(device))
    if kept > RUN_MEMORY:
        raise InputError(f"members: {members} members with {schedule.max_sections} sections "
                         f"of {n} states need {kept / 2**30:.3g} GiB of results; at most "
                         f"{RUN_MEMORY / 2**30:g} GiB: give fewer initial states or grid points, "
                         "or record fewer sections per member")
    if on_gpu(device):
        from analysis.integrate.kernels.cuda import free_memory

        free, _ = free_memory()
        if per > GPU_BLOCK_SHARE * free:
            raise InputError(f"members: one member needs {per} bytes on the GPU, "
                             f"{free} bytes free: record fewer sections per member")


def _block_size(placed: Placement, members: int, per: int, block: int | None) -> int:
    if block is not None:
        return check_count("block", block, 1)
    if not placed.gpu:
        return min(members, CPU_BLOCK)
    from analysis.integrate.kernels.cuda import free_memory

    free, _ = free_memory()
    return max(1, min(members, int(GPU_BLOCK_SHARE * free) // per))


def _kernel(system: System, tangent: bool, device: str | Placement):
    """``cpu_kernel`` or ``gpu_kernel`` by ``device`` (kept for
    ``benchmarks/bench_ensemble.py``'s first-use timing; runs take ``Placement.row.kernel``)."""
    return (gpu_kernel if on_gpu(device) else cpu_kernel)(system, tangent)


def run_members(system: System, states: np.ndarray, parameters: np.ndarray | None,
                h: np.ndarray | float, schedule: Schedule, *,
                t0: np.ndarray | float = 0.0, k0: np.ndarray | int = 0,
                device: str | Placement = CPU, block: int | None = None,
                progress: Callable[[int, int], None] | None = None,
                threads: int | None = None, features: bool = False) -> MemberResult:
    """Run M members of ``system``'s model and balls by ``schedule``.

    ``states`` (M, n): initial states (SI units; a state that is not finite diverges at
    the first step); ``parameters`` (M, n_par): each member's
    full parameter vector (``Model.parameter_vector``; speed in rpm), or None for
    ``system.p`` for all; ``h`` (s; one or per member): the RK4 step; ``t0`` (s) and ``k0``
    (step counters, whole numbers; one or per member): step k runs from ``t0 + k·h``, the
    first from k0. ``device``: a ``Placement`` (``placement.place``, judged once by the
    run that calls), or ``cpu``, ``gpu`` or ``auto``, placed here for these members;
    ``block``: members per call (default: ``CPU_BLOCK`` on the CPU, half the GPU's free
    memory on the GPU); ``progress(done, total)`` after each block (members: on the CPU
without ``block``, after each sub-chunk of about ``PROGRESS_SECONDS`` of work, at least
``CHUNK_PER_THREAD`` members per thread, sized from the chunks before); ``threads``:
    CPU threads (None: the placement's ``threads``, else ``cpu.cores()``, every core; a
    worker process of a pool of W takes cores / W). ``features`` (with
    ``schedule.keep_sections``): ``MemberResult.features``, the sections reduced over K
    (``section_features``): on the GPU on the device, only they are copied back and
    ``sections`` is None; on the CPU the sections are in host memory already and are kept
    (``features`` are computed from them, per block).

    Each member's blow-up limit is ``simulate.blow_up_limit`` of its parameters. Bad input
    raises ``InputError`` before anything runs; a model whose kernel cannot be written or
    built raises ``source.Unsupported`` or ``compiled.CompileError``."""
    model = system.model
    n, n_par = model.n_state, len(model.parameter_names)
    z0 = np.asarray(states, dtype=float)
    if z0.ndim != 2 or z0.shape[1] != n or len(z0) < 1:
        raise InputError(f"states: an array of shape (members, {n}), got shape {z0.shape}")
    m = len(z0)
    if parameters is None:
        p = np.repeat(system.p[None, :], m, axis=0)
    else:
        p = np.asarray(parameters, dtype=float)
        if p.shape != (m, n_par):
            raise InputError(f"parameters: an array of shape ({m}, {n_par}) (full parameter "
                             f"vectors), got shape {p.shape}")
    hs = _per_member("h", h, m, positive=True)
    t0s = _per_member("t0", t0, m, positive=False)
    k0s = _per_member("k0", k0, m, positive=False)
    if np.any(k0s != np.round(k0s)):
        raise InputError("k0: whole numbers")
    placed = device if isinstance(device, Placement) else \
        place(device, m, steps=schedule.total_steps)
    threads = threads or placed.threads
    if features and not schedule.keep_sections:
        raise InputError("features: the reduction of the sections needs a schedule that "
                         "keeps them (keep_sections)")
    reduce = features and placed.gpu
    check_fits(placed, m, schedule, n, n_par, features)
    limits = _limits(system, p, parameters is None)
    kern = placed.row.kernel(system, schedule.tangent)
    counts = schedule.per_member(m)
    k = schedule.max_sections
    sections = np.full((m, k, n), np.nan) if schedule.keep_sections and not reduce else None
    reduced = np.full((m, 2 * n), np.nan) if features else None
    logs = np.full((m, k), np.nan) if schedule.tangent else None
    final, low, high = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    diverged = np.empty(m, dtype=np.int64)
    # a device reduction's temporaries: low, high, total, mean, extent and the features
    size = _block_size(placed, m, _bytes_per_member(schedule, n, n_par)
                       + (8 * 7 * n if reduce else 0), block)
    z0, p = np.ascontiguousarray(z0), np.ascontiguousarray(p)
    width = min(threads or cores(), m)
    chunks = _Chunks(size, width if progress is not None and not placed.gpu
                     and block is None else None)
    start = 0
    while start < m:
        part = slice(start, min(m, start + chunks.size))
        count = part.stop - start
        began = time.perf_counter()
        outs = [np.empty((count, 2 * n)) if reduce else
                np.empty((count, k, n)) if sections is not None else np.empty((1, 1, n)),
                np.empty((count, k)) if logs is not None else np.empty((1, 1)),
                np.empty((count, n)), np.empty(count, dtype=np.int64),
                np.empty((count, n)), np.empty((count, n))]
        ins = [np.ascontiguousarray(a[part]) for a in (z0, k0s, p, hs, t0s, limits, *counts)]
        if reduce:  # outs[0] receives the device's section_features
            kern.run(count, ins, k, schedule.keep_sections, outs, section_features)
        elif placed.gpu:
            kern.run(count, ins, k, schedule.keep_sections, outs)
        else:
            kern.run(count, min(threads or cores(), count), ins, k, schedule.keep_sections,
                     outs)
        if reduce:
            reduced[part] = outs[0]
        elif sections is not None:
            sections[part] = outs[0]
            if reduced is not None:
                reduced[part] = section_features(np, outs[0])
        if logs is not None:
            logs[part] = outs[1]
        final[part], diverged[part], low[part], high[part] = outs[2:]
        chunks.took(count, time.perf_counter() - began)
        start = part.stop
        if progress is not None:
            progress(part.stop, m)
    lambda1 = None
    if logs is not None:
        skip, n_sec, every = counts[3], counts[2], counts[1]
        used = (np.arange(k)[None, :] >= skip[:, None]) & (np.arange(k)[None, :] < n_sec[:, None])
        with np.errstate(invalid="ignore"):
            lambda1 = np.where(used, logs, 0.0).sum(axis=1) / (n_sec - skip) / (every * hs)
    return MemberResult(sections, logs, lambda1, diverged, final, low, high, placed.kind,
                        reduced)


class _Chunks:
    """Members per call of ``run_members``: ``block`` (one size), or with ``width`` threads
    sub-chunks of about ``PROGRESS_SECONDS`` each (a whole number of ``CHUNK_PER_THREAD``
    × ``width`` members, at most ``block``), sized by the rate of the chunks before."""

    def __init__(self, block: int, width: int | None):
        self.block, self.width = block, width
        self.least = CHUNK_PER_THREAD * width if width else block
        self.size = min(block, self.least)

    def took(self, count: int, seconds: float) -> None:
        if not self.width:
            return
        rate = count / seconds if seconds > 0 else math.inf
        want = rate * PROGRESS_SECONDS
        size = self.least * max(1, int(min(want, self.block) // self.least))
        self.size = min(self.block, size)


def blow_up_error(system: System, step: int, h: float, state: np.ndarray) -> SimulationError:
    """The ``SimulationError`` ``simulate`` raises for a member of ``system`` whose
    ``state`` after RK4 step ``step`` (of h s, from t = 0) is its first bad one (the message
    of ``simulate.check_bounded``)."""
    model = system.model
    try:
        check_bounded(np.asarray(state, dtype=float)[:, None], np.array([step * h]),
                      blow_up_limit(model, dict(system.parameters)), model.centre_indices())
    except SimulationError as exc:
        return exc
    return SimulationError(f"the motion blew up at t = {step * h:.6g} s")


def _limits(system: System, p: np.ndarray, shared: bool) -> np.ndarray:
    """Each member's blow-up limit (m), ``simulate.blow_up_limit`` of its parameters."""
    model = system.model
    if shared:
        return np.full(len(p), blow_up_limit(model, dict(system.parameters)))
    names = model.parameter_names
    unique, inverse = np.unique(p, axis=0, return_inverse=True)
    values = [blow_up_limit(model, dict(zip(names, row.tolist(), strict=True)))
              for row in unique]
    return np.ascontiguousarray(np.asarray(values, dtype=float)[np.ravel(inverse)])


def check_kernels(systems: Iterable[System], device: str | Placement,
                  tangent: bool = False) -> None:
    """Build, or load from the cache, and self-test the member kernel (the state variant,
    or the tangent variant with ``tangent``) of each model and balls among ``systems``
    (``System``s) on ``device`` (a ``Placement``, or ``"cpu"`` or ``"gpu"``), before a run's
    work: ``placement.place`` with these systems (a run that places its device itself
    builds them there). ``DeviceError``, one line naming ``device``, the model and its balls
    and the reason, when the kernel cannot be written, built or loaded, or when no GPU can
    be used."""
    place(device, 1, list(systems), "tangent" if tangent else "state")


